// carousel.pov -- textured objects with edges and highlights moving and
// rotating at different speeds, driven by the clock (seconds): the
// animation scene of make anim.
//
// Exercises: motion blur and frame-rate conversion where an image has
// everything at once: a checkered sphere rolling across the floor (edges
// translating and rotating), a striped box spinning fast about its vertical
// axis (edges in time faster than the frame rate), a glossy sphere orbiting
// slowly (a moving highlight), a marble cylinder at rest (the static part).
// One point light with phong highlights and a shadowless fill keep renders
// fast. At clock 0 it is an ordinary still. The motion repeats every 4 s.
// The camera follows the image aspect.

#version 3.7;

#declare T = clock;

global_settings {
  assumed_gamma 1.0
  ambient_light rgb 1
  max_trace_level 5
}

camera {
  perspective
  location  <0, 2.2, -7>
  look_at   <0, 0.7, 0>
  right     x * image_width / image_height
  up        y
  angle     50
}

background { rgb <0.55, 0.6, 0.68> }

light_source { <-5, 8, -6> rgb 0.9 }
light_source { <6, 3, -7> rgb 0.25 shadowless }

#declare Soft = finish { ambient 0.15 diffuse 0.75 specular 0 }
#declare Glossy = finish { ambient 0.1 diffuse 0.6 phong 0.9 phong_size 80 reflection 0.05 }

// floor: a fine tiling, static
plane {
  y, 0
  pigment { checker rgb <0.65, 0.62, 0.56> rgb <0.45, 0.43, 0.40> scale 0.5 }
  finish { Soft }
}

// back wall
plane {
  z, 5
  pigment { gradient y color_map { [0 rgb <0.5, 0.55, 0.62>] [1 rgb <0.72, 0.78, 0.85>] } scale 8 }
  finish { Soft }
}

// rolling checkered sphere: rolls without slipping back and forth across
// the floor, x from -2.4 to 2.4 and back every 4 s (at most 3.8 units a
// second)
#declare R1 = 0.6;
#declare X1 = -2.4 + 2.4 * (1 - cos(2 * pi * T / 4));
sphere {
  0, R1
  pigment { checker rgb <0.9, 0.15, 0.1> rgb <0.95, 0.92, 0.85> scale 0.3 }
  finish { Glossy }
  rotate -z * degrees(X1 / R1)
  translate <X1, R1, -0.8>
}

// spinning striped box: two turns a second
box {
  <-0.5, 0, -0.5>, <0.5, 1.4, 0.5>
  pigment { gradient x color_map { [0 rgb <0.1, 0.2, 0.6>] [0.5 rgb <0.1, 0.2, 0.6>]
                                   [0.5 rgb <0.95, 0.85, 0.3>] [1 rgb <0.95, 0.85, 0.3>] }
            scale 0.25 }
  finish { Glossy }
  rotate y * 720 * T
  translate <1.6, 0, 1.2>
}

// glossy sphere orbiting the cylinder slowly: a highlight that moves
#declare A3 = 2 * pi * T / 4;
sphere {
  0, 0.45
  pigment { rgb <0.2, 0.6, 0.3> }
  finish { Glossy }
  translate <-0.4 + 1.3 * cos(A3), 0.45 + 0.6 * (1 + sin(2 * A3)), 1.8 + 1.3 * sin(A3)>
}

// marble cylinder at rest
cylinder {
  <-0.4, 0, 1.8>, <-0.4, 0.5, 1.8>, 0.5
  pigment { marble turbulence 0.4 color_map { [0 rgb <0.85, 0.82, 0.78>] [1 rgb <0.5, 0.45, 0.42>] } scale 0.6 }
  finish { Soft }
}
