// sweep.pov -- a pattern translating at a known velocity, known in closed
// form at every time: the truth of every sub-frame, shutter integral and
// frame-rate conversion (make anim, the animation study).
//
// Exercises: space-time projection against an analytic truth. As in
// zoneplate.pov, radiance equals the pigment exactly (flat finish, no light,
// no antialiasing), so f(u, v, t) is known everywhere.
//
// Truth, with u, v in [0, 1] across the frame (u to the right, v downwards,
// (0, 0) the top-left corner) and t = POV-Ray's clock in seconds, the
// pattern moving to the right at SW_V frame widths per second:
//
//   SW_PATTERN = 0 (default), a zone plate:
//     f(u, v, t) = 1/2 + 1/2 cos(ZP_K ((u - SW_V t - 1/2)^2 + (v - 1/2)^2))
//   SW_PATTERN = 1, vertical bars of period SW_P frame widths (edges in time):
//     f(u, v, t) = 1 where frac((u - SW_V t) / SW_P) < 1/2, else 0
//
// Sample (i, j) of a W x H render is f((i + 1/2) / W, (j + 1/2) / H, t).
// Defaults: ZP_K = 0.7 pi 64 (0.7 of Nyquist at the middle of the left and
// right edges for a 64-pixel-wide output, as zoneplate.pov), SW_V = 0,
// SW_P = 1/8. At clock 0 the zone plate is zoneplate.pov's.
//
// Override on the command line:  Declare=SW_V=0.05 Clock=0.5
// Scene coordinates: the plane z = 0, the orthographic camera maps world
// (X, Y) = (u, 1 - v).

#version 3.7;

#ifndef (ZP_K)
  #declare ZP_K = 0.7 * pi * 64;
#end
#ifndef (SW_V)
  #declare SW_V = 0;
#end
#ifndef (SW_P)
  #declare SW_P = 1 / 8;
#end
#ifndef (SW_PATTERN)
  #declare SW_PATTERN = 0;
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
  right     <1, 0, 0>
  up        <0, 1, 0>
}

background { rgb 0 }

#declare SW_U0 = SW_V * clock;  // the pattern's shift at this time
#if (SW_PATTERN = 0)
  #declare SW_F = function(x, y, z) {
    0.5 + 0.5 * cos(ZP_K * ((x - SW_U0 - 0.5) * (x - SW_U0 - 0.5) + ((1 - y) - 0.5) * ((1 - y) - 0.5)))
  }
#else
  #declare SW_F = function(x, y, z) {
    select((x - SW_U0) / SW_P - floor((x - SW_U0) / SW_P) - 0.5, 1, 0)
  }
#end

plane {
  z, 0
  pigment {
    function { SW_F(x, y, z) }
    color_map { [0 rgb 0] [1 rgb 1] }
  }
  finish { ambient 1 diffuse 0 specular 0 phong 0 reflection 0 }
}
