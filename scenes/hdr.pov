// hdr.pov -- dark surroundings with small, very bright highlights.
//
// Exercises: the high-dynamic-range limitation (docs/design.md section 6). A
// small emitter (radiance 50, about 2 output pixels across at 64 px wide), a
// tiny one (radiance 1000, under 1 output pixel across at 64 px), sharp
// specular highlights and mirror images of the emitters (peaks of about 4 to
// 40) sit in a scene whose diffuse values are a few hundredths to a few
// tenths (median about 0.02).
// Min-error projection rings around such peaks: expect negative lobes and
// overshoot; highlight compression, clamping or a local min/max clamp change
// the result, which is what this scene is for.
//
// All values are finite in half precision (largest 65504). No jitter, no
// area light, no radiosity: deterministic. The camera follows the image aspect.

#version 3.7;

global_settings {
  assumed_gamma 1.0
  ambient_light rgb 1
  max_trace_level 5
}

camera {
  perspective
  location  <0, 1.6, -5.5>
  look_at   <0, 0.7, 0>
  right     x * image_width / image_height
  up        y
  angle     45
}

background { rgb 0.004 }

#declare EmitterPos = <0.9, 1.9, 0.4>;

// The main emitter: a small sphere of radiance 50, with a point light in it
// that lights the scene (looks_like objects cast no shadow).
light_source {
  EmitterPos
  rgb 12
  fade_distance 1.5
  fade_power 2
  looks_like {
    sphere { 0, 0.07
      pigment { rgb 1 }
      finish { emission 50 ambient 0 diffuse 0 specular 0 }
    }
  }
}

// A tiny, very bright emitter far back: radius 0.04 at about 8.6 units,
// about 0.7 output pixels across at 64 px (3 rendered pixels at factor 4).
sphere {
  <-1.3, 2.3, 3.0>, 0.04
  pigment { rgb 1 }
  finish { emission 1000 ambient 0 diffuse 0 specular 0 }
  no_shadow
}

// Dark floor with a weak mirror reflection (reflects the emitters).
plane {
  y, 0
  pigment { rgb 0.03 }
  finish { ambient 0 diffuse 0.6 specular 0 reflection 0.08 }
}

// Dark wall far behind.
plane {
  z, 6
  pigment { rgb 0.02 }
  finish { ambient 0 diffuse 0.6 }
}

// Glossy black sphere: a sharp specular highlight from the point light.
sphere {
  <-0.8, 0.6, 0.3>, 0.6
  pigment { rgb 0.02 }
  finish { ambient 0 diffuse 0.5 specular 1.5 roughness 0.0008 reflection 0.1 }
}

// Chrome-like sphere: mirror image of both emitters.
sphere {
  <0.9, 0.4, -0.5>, 0.4
  pigment { rgb 0.05 }
  finish { ambient 0 diffuse 0.2 specular 1 roughness 0.001 reflection 0.6 }
}

// A grey box with a phong highlight on its faces and one bright edge.
box {
  <-0.35, 0, -0.35>, <0.35, 0.5, 0.35>
  rotate y * 30
  translate <1.9, 0, 1.4>
  pigment { rgb 0.08 }
  finish { ambient 0 diffuse 0.6 phong 1 phong_size 300 }
}
