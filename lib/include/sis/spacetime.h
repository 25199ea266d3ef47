#pragma once
// Space-time projection of a dynamic scene (docs/design.md section 16): the
// sub-frames, point samples in time, each projected by form() onto the
// spatial space; the output frames sums of their coefficients with the
// temporal weights of sis/time.h, displayed by the spatial display. The
// engine entry point of siproject --fps (and of front ends to come).
#include <functional>
#include <string>
#include <vector>

#include "sis/settings.h"
#include "sis/time.h"

namespace sis {

struct SpaceTimeOptions {
  double fps = 0;           // output frame rate (> 0)
  Shutter shutter;          // open on [T + P/360/fps, T + (P + A)/360/fps)
  int degree = 3;           // temporal B-spline degree, 0..3
  double step = 0;          // temporal lattice step in seconds (0: the sub-frames' mean spacing)
  TimeModel model = TimeModel::Cubic;  // the sub-frames' model in the acquisition
  std::vector<long> frames; // output frame numbers, time k/fps (empty: every whole frame inside)
};

// Sub-frame k's time: its metadata attribute sis:time (a number, or a string
// that parses as one). Throws InputError naming the file when it is missing
// or not a number.
double subframe_time(const std::string& path);

// What the frames need, decided before any sample is read: the times
// checked, the frames (given ones inside the sub-frames' span, else the
// default ones), and each frame's sub-frame weights (frame_weights, or
// conventional_frame_weights for the conventional method), every
// sub-frame inspected to have the first one's size and channels.
struct SpaceTimePlan {
  std::vector<std::string> paths;
  std::vector<double> times;
  std::vector<long> frames;
  std::vector<double> frame_times;
  std::vector<std::vector<double>> weights;  // [frame][sub-frame]
  // Sub-frames whose |weight| is below kWeightFloor times the frame's
  // largest are left out of it (their share of the frame: below K x 1e-12).
  std::vector<long> lo, hi;  // [frame]: the sub-frames it reads, lo..hi
  SpaceTimeOptions options;
  bool conventional = false;
};
inline constexpr double kWeightFloor = 1e-12;

// Throws RequestError (options: --fps, --shutter, --time-degree, --time-step,
// --frames, --times) or InputError (a sub-frame: its file named).
SpaceTimePlan plan_frames(const std::vector<std::string>& paths, std::vector<double> times,
                          const SpaceTimeOptions& options, const Resolved& resolved);

// One output frame: its number and time, its coefficients (the weighted sum
// of the sub-frames') and its final image.
struct SpaceTimeFrame {
  long number = 0;
  double time = 0;
  Coefficients coefficients;
  FinalImage final;
  Display display;
  int alpha = -1;
  std::vector<std::string> channel_names;
};

// Forms the plan's frames in order, handing each to `sink`. Keeps a window
// of sub-frame coefficients: those some later frame still reads (lo..hi of
// the frames to come), each projected once while the windows move forward.
// The result does not depend on the thread count (the sums run in the order
// of the sub-frames). --clamp local is refused (RequestError).
void form_frames(const Settings& settings, const Resolved& resolved, const SpaceTimePlan& plan,
                 const std::function<void(SpaceTimeFrame&)>& sink);

}  // namespace sis
