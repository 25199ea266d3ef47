// objects.pov -- a "not-so-synthetic" still life.
//
// Exercises: the ordinary case, where most of the image is smooth: shaded
// curved surfaces, gentle low-frequency textures, rounded and soft edges,
// soft shadows, and few pathological frequencies (no horizon, no fine
// pattern). The L2 error and high-pass measures of the methods should here
// reflect approximation quality rather than aliasing.
//
// Scene: a floor and a back wall (a closed "studio" corner, so nothing runs
// to a horizon), a marble sphere, a rounded box (superellipsoid) with a
// soft wood-like pigment of wide rings, a matte sphere with a vertical colour
// gradient and a short cylinder. One area light (5 x 5, no jitter, adaptive
// sampling with the fixed grid: deterministic) gives soft shadows; a
// shadowless fill light and ambient 0.15 keep shadows open. Values stay
// roughly in [0, 1] (low dynamic range). The camera follows the image aspect.

#version 3.7;

global_settings {
  assumed_gamma 1.0
  ambient_light rgb 1
  max_trace_level 5
}

camera {
  perspective
  location  <0, 2.0, -6.5>
  look_at   <0, 0.8, 0>
  right     x * image_width / image_height
  up        y
  angle     50
}

background { rgb <0.6, 0.65, 0.7> }

light_source {
  <-4, 7, -5>
  rgb 0.75
  area_light x * 1.5, z * 1.5, 5, 5
  adaptive 1
  circular
  orient
  // no jitter: the same shadow rays on every run
}

light_source { <6, 3, -7> rgb 0.25 shadowless }

#declare Soft = finish { ambient 0.15 diffuse 0.75 specular 0.1 roughness 0.05 }

// floor: a faint, large-scale mottling
plane {
  y, 0
  pigment {
    bozo
    color_map { [0 rgb <0.62, 0.58, 0.52>] [1 rgb <0.70, 0.66, 0.60>] }
    scale 3
  }
  finish { Soft specular 0 }
}

// back wall: a slow vertical gradient
plane {
  z, 4
  pigment {
    gradient y
    color_map { [0 rgb <0.55, 0.60, 0.66>] [1 rgb <0.75, 0.80, 0.86>] }
    scale 8
  }
  finish { Soft specular 0 }
}

// marble sphere, gentle veins
sphere {
  <-1.6, 1.0, 0.6>, 1.0
  pigment {
    marble
    turbulence 0.35
    color_map {
      [0.0 rgb <0.85, 0.82, 0.78>]
      [0.7 rgb <0.80, 0.76, 0.72>]
      [1.0 rgb <0.55, 0.50, 0.48>]
    }
    scale 1.2
    rotate z * 35
  }
  finish { Soft specular 0.3 roughness 0.02 }
}

// rounded box, wide soft wood rings
superellipsoid {
  <0.25, 0.25>
  scale <0.75, 0.6, 0.75>
  rotate y * 25
  translate <0.7, 0.6, 0.9>
  pigment {
    wood
    turbulence 0.1
    color_map { [0 rgb <0.70, 0.48, 0.30>] [1 rgb <0.55, 0.35, 0.20>] }
    scale 0.9
    rotate x * 80
  }
  finish { Soft }
}

// matte sphere with a colour gradient
sphere {
  <2.1, 0.55, -0.6>, 0.55
  pigment {
    gradient y
    color_map { [0 rgb <0.25, 0.40, 0.65>] [1 rgb <0.55, 0.70, 0.85>] }
    scale 1.1
    translate y * 0.0
  }
  finish { Soft }
}

// short cylinder with a bevelled look (rounded by a torus)
union {
  cylinder { <0, 0, 0>, <0, 0.35, 0>, 0.45 }
  torus { 0.45, 0.05 translate y * 0.35 }
  pigment { rgb <0.78, 0.72, 0.55> }
  finish { Soft }
  translate <-0.2, 0, -1.4>
}
