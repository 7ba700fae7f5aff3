#pragma once
/// @file
/// Progress of long library work (compensate, predict, calibrate), for a progress bar: the stage
/// and how far it is, `done` of `total` (total 0 = unknown). Called from the working thread, at
/// most every few thousand blocks or once per iteration; the receiver throttles its drawing.

#include <functional>
#include <string_view>

namespace postproc {

using Progress = std::function<void(std::string_view stage, double done, double total)>;

}  // namespace postproc
