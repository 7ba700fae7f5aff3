#pragma once
/// @file
/// The commanded path of a program as the controller runs it (issue 6): every feed move's end
/// point as joint commands q (through the controller map of program_map.hpp), the time at which
/// the interpolator reaches it, and the controller's discrete interpolator that samples the
/// commands at the interpolation period for the time-domain simulator.
///
/// Feed (machine file `feed`, docs/contour.md):
/// - `tool-tip`: F is the path speed of the tool tip in the workpiece frame (TCP programs, parallel
///   machines); a move's length is its tool-tip path length (nominal model, 8 sub-steps);
/// - `combined-axes`: F is √Σ(Δaxis)² per minute over the program axes, degrees counted as mm
///   (Fanuc / Siemens without TCP); a move's length is that root sum of squares;
/// - G93 inverse time: a move lasts 1/F minutes whatever its length.
/// Limits (per axis, [axes.X] / [drives.q1]): a move is slowed until no joint exceeds its
/// max_velocity; with max_acceleration, the look-ahead profile (forward and backward passes over
/// the whole run) keeps every joint's acceleration along a move within its limit, and the speed at
/// a junction is limited by the corner rule in force ([interpolator] in the machine file, or the
/// program's blending words; docs/contour.md "Corners"): corner time (every joint's velocity jump
/// within max_acceleration · corner_time) or corner tolerance (a circular blend deviating at most
/// the tolerance, its centripetal acceleration and jerk within every joint's limits).
/// max_jerk: the interpolator's output passes a moving average of max_acceleration / max_jerk per
/// joint (the equivalent time constant that makes a trapezoidal ramp an S-curve of that jerk).
///
/// A run is a stretch of consecutive feed moves (G1, G2/G3 as chords, not drilling cycles) in one
/// controller context; rapids, dwells, program stops, context changes and refused blocks end a
/// run, and every run starts and ends at rest.

#include <cstdint>
#include <functional>
#include <string_view>
#include <vector>

#include "postproc/machine/program_map.hpp"
#include "postproc/contour/drive.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/line_reader.hpp"
#include "postproc/gcode/resolve.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::contour {

/// One point of the commanded path: the start of a run or the end of a move (an arc contributes
/// its chord points too).
struct PathPoint {
  kin::JointVector q;            ///< commanded joints, mm / degrees
  machine::Command command;         ///< the same point in program coordinates (work coordinates, mm / deg)
  double t = 0;                  ///< time at which the interpolator reaches the point, s
  double speed = 0;              ///< path speed there (feed metric of the move, mm/s; 0 at rest)
  std::uint64_t line = 0;        ///< source line of the move ending here (of the run's first move for a run start)
  std::uint32_t column = 1;
  std::uint32_t motion = 0;      ///< index of the move ending here among the program's motions
  std::uint32_t map = 0;         ///< index into Path::maps
  bool block_end = true;         ///< false for an arc's inner chord point
  bool run_start = false;        ///< the first point of a run (the end of the previous move, at rest)
};

/// Profile of the move ending at a point (the segment from point i−1 to point i).
struct SegmentProfile {
  double length = 0;       ///< in the feed metric (mm, degrees counted as mm; G93: mm of the combined metric)
  double v_cruise = 0;     ///< mm/s
  double v_start = 0;      ///< speed at the start, mm/s
  double v_end = 0;        ///< speed at the end, mm/s
  double accel = 0;        ///< path acceleration limit, mm/s² (∞ without limits)
  double duration = 0;     ///< s
};

/// A stretch of points [begin, end) moving continuously (start and end at rest).
struct Run {
  std::size_t begin = 0;
  std::size_t end = 0;
  [[nodiscard]] std::size_t size() const { return end - begin; }
};

struct Path {
  std::vector<PathPoint> points;
  std::vector<SegmentProfile> segments;  ///< segments[i]: from point i−1 to point i (unused at run starts)
  std::vector<Run> runs;
  std::vector<machine::ProgramMap> maps;    ///< controller contexts (form, offsets, tool length)
  std::vector<Drive> drives;             ///< per joint
  int joints = 0;
  double period = 0.001;                 ///< interpolation period, s
  std::uint64_t blocks = 0;              ///< lines of the program
  std::uint64_t motions = 0;             ///< motions seen (feed moves, rapids, cycles)
  std::uint64_t feed_moves = 0;          ///< moves on the path
  std::uint64_t arcs = 0;                ///< arcs taken as chords
  double duration = 0;                   ///< total time of the runs, s
  /// Per joint: the window of the moving average on the interpolator's output, s (max_acceleration
  /// / max_jerk; 0 without a jerk limit).
  std::vector<double> jerk_window;
  /// F measures the combined rate of the program axes (machine file feed = combined-axes): a
  /// move's time then follows its axis lengths, so corrected axis values change it.
  bool combined_feed = false;
};

struct PathOptions {
  /// Chord tolerance for arcs on the path, mm.
  double arc_tolerance_mm = 0.0005;
  /// For paths that only describe the intended contour (the reference of simulate and of the
  /// verification): a linear feed move longer than this in the feed metric (mm, degrees as mm)
  /// gets inner points (block_end false) at most this far apart, interpolated as the controller
  /// interpolates it (the program coordinates linearly, a tool vector normalised): the contour
  /// fitted through the block end points alone cuts across a long move whose tool tip or tool
  /// axis the controller moves along a curve (rotary axes turning). 0: none (the commanded path).
  double densify_mm = 0;
};

/// PathOptions::densify_mm of the intended contour that `simulate` and compensate's verification
/// measure against (mm, degrees as mm).
inline constexpr double kReferenceDensifyMm = 1.0;

/// The model of path point i: the calibrated (or, with `nominal`, the controller's nominal) model
/// of the point's controller context, which carries the block's tool length; `fallback` for paths
/// built by hand without contexts (Path::maps empty).
[[nodiscard]] inline const kin::Model& model_at(const Path& p, std::size_t i, const kin::Model& fallback,
                                                bool nominal = false) {
  if (p.maps.empty()) return fallback;
  const machine::ProgramMap& m = p.maps[p.points[i].map];
  return nominal ? m.nominal() : m.actual();
}

/// Diagnostics: PP-E611 a joint has no servo data (kv); PP-E612 a move has no feed; PP-E602 /
/// PP-E604 as compensate (machine data missing, kinematics failed). Errors are reported to
/// `sink`; the path is still returned with what could be built.
[[nodiscard]] Path build_path(gcode::LineReader& in, std::string_view file, const gcode::Dialect& d,
                              const machine::Machine& m, const PathOptions& opt, gcode::DiagnosticSink& sink);
/// The same on a program held in memory that may use parameters, subprograms or control flow: it
/// is resolved first (gcode/resolve.hpp, with `resolve`), and the points carry source lines.
[[nodiscard]] Path build_path(std::string_view text, std::string_view file, const gcode::Dialect& d,
                              const machine::Machine& m, const PathOptions& opt, gcode::DiagnosticSink& sink,
                              const gcode::ResolveOptions& resolve);

/// The servo drive of every joint of `m`: [drives.<joint>] when given, else [axes.<letter>] of the
/// program axis of that name. Missing Kv: nullopt and an error naming the table to add.
[[nodiscard]] std::optional<std::vector<Drive>> joint_drives(const machine::Machine& m, std::string& why);

/// One command sample of the discrete interpolator.
struct Sample {
  double t = 0;             ///< s
  kin::JointVector q;       ///< commanded joints, mm / degrees
  std::size_t segment = 0;  ///< the point the sample moves toward (segment index)
  double fraction = 0;      ///< how far along that segment, 0…1
};

/// The controller's interpolator over one run: samples at t = k·period from the run's start
/// until the run's end time, then `settle` seconds more at rest at the end point. Axis programs
/// interpolate the joints linearly; tool-tip programs interpolate the tool tip and the tool axis
/// linearly (the axis normalised) and take the joints from the controller's nominal inverse
/// kinematics. Along a segment the path position follows the segment's speed profile. Joints with
/// a jerk window (Path::jerk_window) get the moving average of their commands over that window; the
/// run then lasts the longest window longer before `settle` starts.
void interpolate(const Path& path, const Run& run, double settle, const std::function<void(const Sample&)>& visit);

}  // namespace postproc::contour
