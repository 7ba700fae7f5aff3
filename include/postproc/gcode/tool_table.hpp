#pragma once
/// @file
/// LinuxCNC tool table files (`tool.tbl`): one tool per line, `T<n> P<pocket> Z<length> D<diameter>
/// ;comment` (LinuxCNC "Tool Table Format"). The interpreter resolves G43 H / G43 and G41/G42 from it.

#include <string>

#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/dialect.hpp"

namespace postproc::gcode {

/// Reads `path` into `opt.tool_lengths` (Z, mm), `opt.tool_radii` (D / 2, mm) and
/// `opt.tool_orientations` (Q, lathe tool orientation 0–9) by tool number.
/// Values are taken in mm (the machine's linear units must be mm). Bad lines are reported located
/// (PP-E208) and make the result false; nothing is guessed.
bool read_linuxcnc_tool_table(const std::string& path, DialectOptions& opt, DiagnosticSink& sink);

}  // namespace postproc::gcode
