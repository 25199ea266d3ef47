// zoneplate.pov -- a zone plate known in closed form, for exact-error tests.
//
// Exercises: the whole pipeline against an analytic truth. Radiance equals
// the pigment exactly (flat finish, no light, no antialiasing), so the C++
// side can evaluate f at any point and measure the continuous L2 error, the
// aliasing of each method, and the pixel-centre convention of section 2.
//
// Truth, with u, v in [0, 1] across the frame (u to the right, v downwards,
// (0, 0) the top-left corner of the image):
//
//     f(u, v) = 1/2 + 1/2 * cos(ZP_K * ((u - 1/2)^2 + (v - 1/2)^2))
//
// Values lie in [0, 1]; f = 1 at the centre (u, v) = (1/2, 1/2).
//
// Mapping from image coordinates: for a render of W x H pixels, a point at
// (x, y) in rendered pixels (x = 0 left edge, y = 0 top edge, y downwards)
// has u = x / W, v = y / H. POV-Ray with -A traces pixel (i, j) (column i,
// row j, row 0 on top) at its centre, so sample (i, j) is
//
//     f((i + 1/2) / W, (j + 1/2) / H).
//
// In output pixels of an output image w x h rendered with factor s
// (W = s w, H = s h), the same point is u = x_out / w, v = y_out / h.
// The frame is always the unit square, whatever the aspect: a non-square
// image stretches the plate (this scene alone does not follow the image
// aspect, on purpose).
//
// Local frequency: the phase is ZP_K r^2 with r the distance from the centre
// in (u, v); along u it has 2 ZP_K (u - 1/2) radians per unit, i.e.
// ZP_K |u - 1/2| / (pi W) cycles per pixel of a W-wide image. At the middle
// of the left and right edges (|u - 1/2| = 1/2) that is ZP_K / (2 pi W).
// The default ZP_K = 0.7 * pi * 64 (about 140.74) puts that at 0.35 cycles
// per pixel = 0.7 of the Nyquist rate (0.5) for a 64-pixel-wide output; in
// the corners each axis component is also 0.35 (radial 0.49).
// For another output width w and fraction q of Nyquist: ZP_K = q * pi * w.
//
// Override on the command line:  Declare=ZP_K=201.06
//
// Scene coordinates: the plate lies in the plane z = 0; the orthographic
// camera maps world (X, Y) = (u, 1 - v) (POV-Ray's y axis points up).

#version 3.7;

#ifndef (ZP_K)
  #declare ZP_K = 0.7 * pi * 64;
#end

global_settings {
  assumed_gamma 1.0
  ambient_light rgb 1
  max_trace_level 1
}

camera {
  orthographic
  location  <0.5, 0.5, -1>
  direction <0, 0, 1>
  right     <1, 0, 0>     // the unit square, whatever the image aspect
  up        <0, 1, 0>
}

background { rgb 0 }

// u = x, v = 1 - y
#declare ZP_F = function(x, y, z) {
  0.5 + 0.5 * cos(ZP_K * ((x - 0.5) * (x - 0.5) + ((1 - y) - 0.5) * ((1 - y) - 0.5)))
}

plane {
  z, 0
  pigment {
    function { ZP_F(x, y, z) }
    color_map { [0 rgb 0] [1 rgb 1] }
  }
  finish { ambient 1 diffuse 0 specular 0 phong 0 reflection 0 }
}
