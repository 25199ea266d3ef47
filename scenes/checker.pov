// checker.pov -- infinite checkerboard running to the horizon.
//
// Exercises: aliasing and moire, the classic test. Near the camera the
// squares are large with sharp edges; towards the horizon their frequency
// grows without bound, so every sampling rate aliases somewhere and every
// method shows its moire. Values are exactly 0 and 1 on the plane (flat
// finish: ambient 1, diffuse 0, no light), and a plain sky colour above the
// horizon, so the scene is low dynamic range and noise-free.
//
// Geometry: unit squares on the plane y = 0, turned 20 degrees about y so that
// neither family of edges lines up with the pixel grid; the eye is 1 unit
// above the plane, pitched 15 degrees down, horizontal field of view 60
// degrees: the horizon lies about a quarter of the image height below the
// top edge (for a square image). The camera follows the image aspect.

#version 3.7;

global_settings {
  assumed_gamma 1.0
  ambient_light rgb 1
  max_trace_level 1
}

camera {
  perspective
  location  <0, 1, 0>
  direction <0, 0, 1>
  right     x * image_width / image_height
  up        y
  angle     60
  rotate    x * 15          // pitch down
}

background { rgb <0.5, 0.7, 1.0> }   // plain sky

plane {
  y, 0
  pigment { checker rgb 0, rgb 1 rotate y * 20 }
  finish { ambient 1 diffuse 0 specular 0 phong 0 reflection 0 }
}
