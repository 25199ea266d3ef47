// edges.pov -- high-contrast discontinuities and thin features, values 0 and 1.
//
// Exercises: ringing (Gibbs overshoot) at step edges, the response to
// features thinner than a pixel, and aliasing of slanted edges and converging
// lines. Every surface is flat (ambient 1, diffuse 0, no light) over a black
// background, so every ray returns exactly 0 or exactly 1: any value outside
// [0, 1] in a result is overshoot of the reconstruction, never of the scene.
//
// Orthographic camera. Scene units: the frame is 1 unit high, y from 0
// (bottom) to 1 (top), and image_width/image_height units wide, centred on
// x = 0.5 (for a square image: the unit square). One unit is H pixels in a
// render H pixels high, so on a 64-pixel-high output 1/64 is one output pixel.
// Pixel (i, j) of a W x H render (row 0 on top) sees the point
//     x = 0.5 + ((i + 1/2) / W - 1/2) * W / H,   y = 1 - (j + 1/2) / H.
//
// Layout (square image; wider images show more black at the sides):
//   top row (y 0.68 .. 0.96), white on black:
//     - axis-aligned rectangle: edges exactly on x = 0.05, 0.31 and
//       y = 0.68, 0.96;
//     - square of side 0.26 turned 5 degrees (slanted-edge / MTF target);
//     - disc of radius 0.13 (curved edge, all orientations).
//   middle row (y 0.36 .. 0.64), a white panel with black lines:
//     - five vertical lines of widths 1/256, 1/128, 1/64, 1/32, 1/16
//       (0.25 .. 4 output pixels at 64 px), left half;
//     - three thin lines of width 1/128 turned 3, 30 and 45 degrees from the
//       vertical, right half.
//   bottom row (y 0.04 .. 0.32):
//     - white horizontal lines on black, widths 1/256, 1/128, 1/64, 1/32 (left);
//     - a Siemens star: white disc of radius 0.13 with 16 black wedges
//       meeting at the centre (right).

#version 3.7;

global_settings {
  assumed_gamma 1.0
  ambient_light rgb 1
  max_trace_level 1
}

camera {
  orthographic
  location  <0.5, 0.5, -10>
  direction <0, 0, 1>
  right     x * image_width / image_height
  up        y
}

background { rgb 0 }

#declare Flat = finish { ambient 1 diffuse 0 specular 0 phong 0 reflection 0 }
#declare White = texture { pigment { rgb 1 } finish { Flat } }
#declare Black = texture { pigment { rgb 0 } finish { Flat } }

// Depth order along +z (the camera looks along +z): panels at z = 1,
// features on them at z = 0 (nearer, so they cover the panels).

// ---- top row: white shapes on black --------------------------------------
box { <0.05, 0.68, 0.9>, <0.31, 0.96, 1.1> texture { White } }

box { <-0.13, -0.13, 0.9>, <0.13, 0.13, 1.1>
  rotate z * 5
  translate <0.5, 0.82, 0>
  texture { White }
}

cylinder { <0.82, 0.82, 0.9>, <0.82, 0.82, 1.1>, 0.13 texture { White } }

// ---- middle row: black lines on a white panel ----------------------------
box { <-10, 0.36, 0.9>, <10, 0.64, 1.1> texture { White } }

#declare Widths = array[5] { 1/256, 1/128, 1/64, 1/32, 1/16 }
#declare I = 0;
#while (I < 5)
  #declare Xc = 0.08 + I * 0.08;
  box { <Xc - Widths[I]/2, 0.38, -0.1>, <Xc + Widths[I]/2, 0.62, 0.1>
    texture { Black } }
  #declare I = I + 1;
#end

#declare Angles = array[3] { 3, 30, 45 }
#declare Xcs = array[3] { 0.55, 0.64, 0.85 }
#declare I = 0;
#while (I < 3)
  // a line of width 1/128 through (xc, 0.5), clipped to the panel's band
  intersection {
    box { <-1/256, -0.5, -0.1>, <1/256, 0.5, 0.1>
      rotate -z * Angles[I]
      translate <Xcs[I], 0.5, 0>
    }
    box { <0.5, 0.38, -0.2>, <1.0, 0.62, 0.2> }
    texture { Black }
  }
  #declare I = I + 1;
#end

// ---- bottom row -----------------------------------------------------------
#declare I = 0;
#while (I < 4)
  #declare Yc = 0.08 + I * 0.07;
  box { <0.04, Yc - Widths[I]/2, 0.9>, <0.46, Yc + Widths[I]/2, 1.1>
    texture { White } }
  #declare I = I + 1;
#end

// Siemens star: 16 black wedges of 11.25 degrees (every other 22.5-degree
// sector) over a white disc.
#declare StarC = <0.75, 0.18, 0>;
#declare StarR = 0.13;
cylinder { StarC + <0, 0, 0.9>, StarC + <0, 0, 1.1>, StarR texture { White } }
#declare I = 0;
#while (I < 16)
  #declare D0 = <cos(radians(I * 22.5)), sin(radians(I * 22.5)), 0>;
  #declare D1 = <cos(radians(I * 22.5 + 11.25)), sin(radians(I * 22.5 + 11.25)), 0>;
  intersection {          // the sector between directions D0 and D1
    plane { < D0.y, -D0.x, 0>, 0 }
    plane { <-D1.y,  D1.x, 0>, 0 }
    cylinder { -z, z, StarR }
    translate StarC
    texture { Black }
  }
  #declare I = I + 1;
#end
