#pragma once
// The Klartext interpreter's state and its steps (klartext.hpp); the steps are defined in
// klartext_interpreter.cpp (blocks, M functions, the run loop), klartext_paths.cpp (path functions)
// and klartext_cycles.cpp (cycles, frames, PLANE, FUNCTION).
#include <array>
#include <map>
#include <numbers>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>
#include <fmt/format.h>

#include "src/gcode/codes.hpp"
#include "src/gcode/klartext.hpp"
#include "src/gcode/text.hpp"

namespace postproc::gcode::klartext {


inline constexpr double kPi = std::numbers::pi;
inline constexpr double kDeg = kPi / 180.0;
inline constexpr AxisMask kLinear = bit(Axis::x) | bit(Axis::y) | bit(Axis::z);
inline constexpr AxisMask kRotary = bit(Axis::a) | bit(Axis::b) | bit(Axis::c);

/// Address words of a motion block, by meaning.
struct Words {
  std::array<std::int16_t, kAxisCount> axis{};  ///< word index per axis, -1 none
  AxisMask present = 0, incremental = 0;
  std::array<double, kAxisCount> value{};
  std::int16_t pr = -1, pa = -1;     ///< polar radius / angle words
  bool ipr = false, ipa = false;
  double pr_v = 0, pa_v = 0;
  std::int16_t r = -1;               ///< CR radius / RND radius
  double r_v = 0;
  std::int16_t f = -1;
  double f_v = 0;
  bool fmax = false, fauto = false, fu = false, fz = false;
  int dr = 0;                        ///< DR+ = +1, DR- = -1
  int comp = -1;                     ///< R0 = 0, RL = 1, RR = 2, R+/R- = 3; -1 not stated
  Span comp_at;
  std::array<std::int16_t, 3> n{-1, -1, -1}, t{-1, -1, -1};  ///< NX NY NZ, TX TY TZ
  Eigen::Vector3d n_v = Eigen::Vector3d::Zero(), t_v = Eigen::Vector3d::Zero();
  std::vector<std::pair<int, Span>> m;  ///< M numbers in order
  std::int16_t mb = -1;              ///< M140 MB distance word
  bool mb_max = false;
  std::int16_t unread = -1;          ///< first word this version does not read here
  std::int16_t unread_keyword = -1;  ///< token index of the first keyword it does not read here
};

/// One program's interpretation: state carried from block to block.
class Interp {
 public:
  Interp(const Dialect& d, std::string_view file, DiagnosticSink& sink) : d_(d), file_(file), sink_(sink) {
    for (int a = 0; a < kAxisCount; ++a) rollover_[static_cast<std::size_t>(a)] = d.rollover[static_cast<std::size_t>(a)];
  }

  [[nodiscard]] bool inch() const { return inch_; }

  void execute(const Block& b, MotionSink& out);

 private:
  // ---- reporting ----
  void report(const Block& b, Span at, Severity sev, std::string_view code, std::string msg) {
    report_at(LexContext{file_, &sink_}, b, at, sev, code, std::move(msg));
  }
  void warn(const Block& b, Span at, std::string_view code, std::string msg) {
    report(b, at, Severity::warning, code, std::move(msg));
  }
  void error(const Block& b, Span at, std::string msg) {
    report(b, at, Severity::error, codes::kArcGeometry, std::move(msg));
  }
  static bool ends_continued(const Block& b) { return continued(b.raw); }

  // ---- units and planes ----
  double len(double v) const { return inch_ ? v * 25.4 : v; }
  PlaneAxes axes() const { return plane_axes(plane_); }
  /// The plane of the block's contour geometry: CC's plane for C, CP and LP, else the working plane.
  PlaneAxes gaxes() const { return plane_axes(geo_plane_); }

  // ---- words ----
  bool collect(const Block& b, Verb v, Words& w);

  // ---- blocks ----
  void tool_call(const Block& b);
  void circle_centre(const Block& b);
  void motion(const Block& b, Verb v, MotionSink& out);
  /// M functions that act before the move of their block.
  void before_motion_m(const Block& b, int m, Span at);
  bool block_frame_unfollowed(const Block& b);
  /// M functions that act after the move (and non-modal ones that end here).
  void after_motion_m(const Block& b, const Words& w, MotionSink& out);
  void retract(const Block& b, const Words& w, Span at, MotionSink& out);
  bool ln(const Block& b, const Words& w, Motion& m);
  bool centre_ready(const Block& b);
  bool start_known_in_plane(const Block& b);
  void set_arc(Motion& m, const Eigen::Vector2d& c, double sweep, bool full);
  bool arc_about_centre(const Block& b, const Words& w, Motion& m, AxisMask& end_known);
  bool arc_by_radius(const Block& b, const Words& w, Motion& m, AxisMask& end_known);
  bool arc_tangent(const Block& b, const Words& w, Motion& m, AxisMask& end_known);
  bool polar_line(const Block& b, const Words& w, Motion& m, AxisMask& end_known);
  /// The end point of PR/PA words about the pole: absolute or incremental to the current point's
  /// polar coordinates (an omitted PR or PA keeps the current one).
  bool polar_end(const Block& b, const Words& w, Eigen::Vector2d& e);
  bool polar_arc(const Block& b, const Words& w, Motion& m, AxisMask& end_known);
  void tangent_from(const Motion& m);

  // ---- cycles and frames ----
  int cycle_number(const Block& b, double& sub) const;
  void cycle_def(const Block& b);
  bool has_axis_keyword(const Block& b) const;
  void datum_shift(const Block& b, double sub);
  void set_tilt(bool on);
  void plane(const Block& b);
  void function(const Block& b);
  /// "Q200=+2 ;SET-UP CLEARANCE": a parameter of the cycle being defined (a literal; the resolver
  /// writes the value of a formula there).
  void cycle_parameter(const Block& b);
  /// Drilling cycles that stay on the hole axis, as one drill_cycle motion per call (TNC 640 User's
  /// Manual, "Cycles: drilling" / "tapping"): to the set-up clearance Q200 above the surface Q203 at
  /// FMAX, down to the depth Q201 (pecks, dwells and chip breaking stay on the axis), back to the
  /// set-up clearance and on to the 2nd set-up clearance Q204.
  bool drill_call(const Block& b, Span at, MotionSink& out);
  void cycle_call(const Block& b, Span at, MotionSink& out);
  const Dialect& d_;
  std::string_view file_;
  DiagnosticSink& sink_;
  AxisVector pos_ = AxisVector::Zero();
  AxisMask known_ = 0;
  bool inch_ = false, ended_ = false, continuation_ = false;
  double feed_ = 0;
  bool feed_known_ = false;
  FeedMode feed_mode_ = FeedMode::per_minute;
  int comp_ = 0;
  bool comp_reported_ = false, cutter_radius_known_ = false;
  Plane plane_ = Plane::xy;
  Eigen::Vector2d cc_ = Eigen::Vector2d::Zero();
  bool cc_known_ = false;
  Plane cc_plane_ = Plane::xy;
  Plane geo_plane_ = Plane::xy;
  Eigen::Vector3d tangent_ = Eigen::Vector3d::UnitX();
  bool tangent_known_ = false;
  bool polar_words_ = false;
  AxisVector datum_ = AxisVector::Zero();
  /// The datum (preset) the coordinates refer to: the one active at the start is named G54 (as the
  /// ISO dialects' default), cycle 247 Q339=n selects PRESETn (machine::work_offset_name); unknown
  /// while a cycle 247 has not given a literal Q339 (compensate then refuses: PP-E602).
  WorkOffset preset_{};
  bool preset_unknown_ = false;
  bool preset_pending_ = false;  ///< a CYCL DEF 247 whose parameter lines are being read
  bool mirror_ = false, rotation_ = false, scaling_ = false, tilted_ = false, tcp_ = false;
  bool frame_machine_ = false, kinematic_m_ = false, turning_mode_ = false, spindle_ = false, tcp_refpnt_ = false;
  int m92_ = 0;
  Span m92_at_;
  bool tool_active_ = false;
  int tool_number_ = -1;
  int cycle_ = -1;
  std::map<int, double> cycle_params_;  ///< Q number → value of the cycle defined last
  bool cycle_params_open_ = false;
  std::array<RotaryRollover, 9> rollover_{};
};

}  // namespace postproc::gcode::klartext
