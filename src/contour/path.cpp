// The commanded path of a program: feed moves → joint commands with the controller's timing
// (feed interpretation, velocity limits, look-ahead acceleration profile), and the discrete
// interpolator that samples it at the interpolation period.
#include "postproc/contour/path.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <limits>
#include <numbers>

#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/program.hpp"
#include "src/gcode/block_words.hpp"
#include "src/gcode/convert_support.hpp"
#include "src/gcode/number_text.hpp"
#include "src/gcode/text.hpp"
#include "src/gcode/linearize.hpp"

namespace postproc::contour {
namespace {

using gcode::AxisMask;
using gcode::Motion;
using gcode::MotionType;

constexpr std::string_view kMachineData = "PP-E602";
constexpr std::string_view kKinematics = "PP-E604";
constexpr std::string_view kNoFeed = "PP-E612";
constexpr std::string_view kUnknownStart = "PP-E613";
constexpr std::string_view kUnmodelled = "PP-E614";  // a move the contour prediction does not model
/// Path acceleration used where no joint has an acceleration limit, mm/s² (a jump in one period).
constexpr double kUnlimited = 1e12;

struct JointLimits {
  double v = std::numeric_limits<double>::infinity();  ///< unit/s
  double a = std::numeric_limits<double>::infinity();  ///< unit/s²
  double j = std::numeric_limits<double>::infinity();  ///< unit/s³
};

/// The corner rule in force at a junction: the rule and its value (corner time s, tolerance mm or
/// blend distance mm).
struct Blend {
  machine::CornerRule rule = machine::CornerRule::time;
  double value = 0.005;
};

/// Feed-metric length of a segment and its direction in the metric's space: the tool tip's chord
/// (tip = true, first three entries) or the program axes' increments, as a unit vector.
struct Metric {
  double length = 0;
  gcode::AxisVector dir = gcode::AxisVector::Zero();
  bool tip = false;
};

/// max |A·sin α + B·cos α| over α ∈ [0, θ].
double sinusoid_peak(double A, double B, double theta) {
  double m = std::max(std::abs(B), std::abs(A * std::sin(theta) + B * std::cos(theta)));
  const double a0 = std::atan2(A, B);  // stationary points a0 + kπ
  for (int k = -2; k <= 2; ++k) {
    const double a = a0 + k * std::numbers::pi;
    if (a > 0 && a < theta) m = std::max(m, std::abs(A * std::sin(a) + B * std::cos(a)));
  }
  return m;
}

const machine::AxisSettings* settings_of(const machine::Machine& m, const std::string& joint) {
  if (const auto it = m.drives.find(joint); it != m.drives.end()) return &it->second;
  const int ax = joint.size() == 1 ? gcode::axis_index(joint[0]) : -1;
  if (ax >= 0 && m.axes[static_cast<std::size_t>(ax)]) return &*m.axes[static_cast<std::size_t>(ax)];
  return nullptr;
}

/// Points a machine-file diagnostic at the table it names ("[axes.X]" in `why`); when the file has
/// no such table, at the first servo table ([axes.…] / [drives.…]), else at [machine]. Stays about
/// the file as a whole only when the file cannot be read again.
void locate_table(const machine::Machine& m, const std::string& why, gcode::Diagnostic& diag) {
  const auto open = why.find('['), close = why.find(']', open);
  if (open == std::string::npos || close == std::string::npos) return;
  const std::string header = why.substr(open, close - open + 1);
  std::ifstream in(m.file);
  std::string line;
  struct Hit {
    std::uint64_t line = 0;
    std::uint32_t column = 1;
    std::string text;
  } exact, servo, machine;
  for (std::uint64_t n = 1; std::getline(in, line); ++n) {
    const auto b = line.find_first_not_of(" \t");
    if (b == std::string::npos) continue;
    const auto starts = [&](std::string_view h) { return line.compare(b, h.size(), h) == 0; };
    const Hit here{n, static_cast<std::uint32_t>(b + 1), line};
    if (exact.line == 0 && starts(header)) exact = here;
    if (servo.line == 0 && (starts("[axes.") || starts("[drives."))) servo = here;
    if (machine.line == 0 && starts("[machine]")) machine = here;
  }
  const Hit& at = exact.line ? exact : servo.line ? servo : machine;
  if (at.line == 0) return;
  diag.where.line = at.line;
  diag.where.column = at.column;
  diag.length = static_cast<std::uint32_t>(at.text.size() - (at.column - 1));
  diag.source_line = at.text;
}

bool is_stop(const gcode::Block& b) {
  for (const gcode::Word& w : b.words)
    if (w.letter == 'M' && w.name_len == 1 && w.kind == gcode::ValueKind::number) {
      const double v = w.number;
      if (v == 0 || v == 1 || v == 2 || v == 30 || v == 60 || v == 6) return true;
    }
  return false;
}

/// Duration of a trapezoidal move of length L from v0 to v1 under cruise vc and acceleration A
/// (v0, v1 ≤ vc, reachable); also the peak speed used.
double trapezoid(double L, double v0, double v1, double vc, double A, double& peak) {
  if (L <= 0) {
    peak = 0;
    return 0;
  }
  const double da = (vc * vc - v0 * v0) / (2 * A);
  const double dd = (vc * vc - v1 * v1) / (2 * A);
  if (da + dd <= L) {
    peak = vc;
    return (vc - v0) / A + (vc - v1) / A + (L - da - dd) / vc;
  }
  peak = std::sqrt(std::max((2 * A * L + v0 * v0 + v1 * v1) / 2, std::max(v0 * v0, v1 * v1)));
  return (peak - v0) / A + (peak - v1) / A;
}

/// Distance covered after tau seconds of a segment's profile.
double position_at(const SegmentProfile& s, double tau) {
  if (s.duration <= 0 || s.length <= 0) return s.length;
  tau = std::clamp(tau, 0.0, s.duration);
  const double A = s.accel;
  const double vp = s.v_cruise;
  const double ta = (vp - s.v_start) / A;
  const double td = (vp - s.v_end) / A;
  const double tc = std::max(0.0, s.duration - ta - td);
  if (tau <= ta) return s.v_start * tau + 0.5 * A * tau * tau;
  const double sa = s.v_start * ta + 0.5 * A * ta * ta;
  if (tau <= ta + tc) return sa + vp * (tau - ta);
  const double r = tau - ta - tc;
  return std::min(s.length, sa + vp * tc + vp * r - 0.5 * A * r * r);
}

class Builder final : public gcode::BlockVisitor {
 public:
  Builder(std::string_view file, const gcode::Dialect& d, const machine::Machine& m, const PathOptions& opt,
          gcode::DiagnosticSink& sink, Path& path, std::vector<JointLimits> limits)
      : file_(file), m_(m), opt_(opt), sink_(sink), p_(path), track_(d), models_(m), limits_(std::move(limits)), d_(d),
        blend_(machine_blend()) {
    collect_.on_report = [this](const gcode::Diagnostic& diag) { sink_.report(diag); };
  }
  gcode::DiagnosticSink& collector() { return collect_; }

  void block(const gcode::Block& b, std::span<const Motion> motions, bool lexed_ok) override {
    ++p_.blocks;
    track_.update(b);
    update_blend(b);
    // Motions are counted as the writer of --mode contour counts them (every motion of every
    // block that lexed).
    if (lexed_ok) p_.motions += motions.size();
    const bool home = track_.has(gcode::GMeaning::home_return);
    // Exact stop: G9 stops at the end of its block, G61 (Siemens G60) at the end of every block
    // until G64 and friends.
    bool exact_here = false;
    if (const auto* g = track_.find(gcode::GMeaning::exact_stop)) {
      if (g->def->group == gcode::GGroup::non_modal) exact_here = true;
      else exact_mode_ = true;
    }
    if (track_.has(gcode::GMeaning::path_control)) exact_mode_ = false;
    const bool stop = !lexed_ok || home || track_.has(gcode::GMeaning::dwell) || is_stop(b) || motions.size() > 1 ||
                      exact_here || exact_mode_;
    if (lexed_ok && !home && motions.size() == 1) {
      const Motion mo = vector_.apply(motions.front());
      const bool feed = mo.type == MotionType::linear || mo.type == MotionType::arc_cw || mo.type == MotionType::arc_ccw;
      if (feed && !mo.tilted_plane) {
        feed_move(b, mo);
      } else {
        end_run();
        note_position(mo);
      }
    }
    if (stop || (motions.empty() && (track_.has(gcode::GMeaning::work_offset) ||
                                     track_.has(gcode::GMeaning::set_offsets_g10))))
      end_run();
  }

  void finish() { end_run(); }

 private:
  void note_position(const Motion& m) {
    last_vector_ = m.tool_vector;
  }

  void error(const gcode::Block& b, const Motion& m, std::string_view code, std::string why) {
    const gcode::Span s{m.column > 0 ? m.column - 1 : 0, m.column > 0 ? m.column : 1};
    gcode::report_at(gcode::LexContext{file_, &sink_}, b, s, gcode::Severity::error, code, std::move(why));
  }

  /// The controller map of the motion's context (index into p_.maps); -1 after an error.
  int map_for(const gcode::Block& b, const Motion& m) {
    const machine::Form form = machine::form_of(m_, m);
    if (form == machine::Form::turning) {
      // The spinning part (radius and Z) is corrected geometrically; its servo contour is not modelled.
      error(b, m, kUnmodelled,
            "a turning move (the workpiece spindle turns: [machine] turning_spindle, M3/M4) is not modelled by the "
            "contour prediction; compensate it with --mode geometric");
      return -1;
    }
    const auto offset = machine::program_offset(m_, m);
    if (!offset) {
      error(b, m, kMachineData, machine::program_offset_refusal(m_, m));
      return -1;
    }
    const auto tool = machine::tool_length_of(m_, m);
    if (!tool) {
      error(b, m, kMachineData,
            m.tool_length_rewritten
                ? machine::rewritten_length_refusal(m)
                : fmt::format("tool length H{} is not in machine file {}; add [tool.lengths] {} = \"<length> mm\"",
                              m.tool_length_h, m_.file, m.tool_length_h));
      return -1;
    }
    const double length = *tool;
    const bool on_z = form == machine::Form::axes && m.tool_length_active;
    if (map_index_ >= 0 && form == key_form_ && *offset == key_offset_ && on_z == key_on_z_ && length == key_length_)
      return map_index_;
    if (!models_.length_error_known(length)) {
      error(b, m, machine::kToolLengthError,
            models_.unknown_length_error(length, m.tool_length_active ? m.tool_length_h : 0));
      return -1;
    }
    end_run();
    const auto& [nom, act] = models_.with_tool_length(length);
    p_.maps.emplace_back(m_, nom, act, form, *offset, on_z, length);
    key_form_ = form;
    key_offset_ = *offset;
    key_on_z_ = on_z;
    key_length_ = length;
    map_index_ = static_cast<int>(p_.maps.size() - 1);
    return map_index_;
  }

  /// Feed-metric length of the segment between two commands, with its direction.
  Metric metric(const machine::ProgramMap& map, const machine::Command& a, const machine::Command& b, AxisMask mask) const {
    Metric out;
    if (m_.feed == machine::FeedReference::tool_tip) {
      double len = 0;
      Eigen::Vector3d chord = Eigen::Vector3d::Zero();
      if (map.form() != machine::Form::axes) {
        chord = b.c.head<3>() - a.c.head<3>();
        len = chord.norm();
      } else {
        // Tool-tip length of an axis move: the nominal machine's tip along the joint line.
        constexpr int kSteps = 8;
        kin::JointVector qa, qb;
        kin::Pose pa, pb;
        if (map.joints(a, q_, qa).ok() && map.joints(b, q_, qb).ok() && map.nominal().forward(qa, pa).ok()) {
          const Eigen::Vector3d p0 = pa.p;
          for (int k = 1; k <= kSteps; ++k) {
            const kin::JointVector qk = qa + (qb - qa) * (static_cast<double>(k) / kSteps);
            if (!map.nominal().forward(qk, pb).ok()) break;
            len += (pb.p - pa.p).norm();
            pa = pb;
          }
          chord = pa.p - p0;
        }
      }
      if (len > 1e-9) {
        out.length = len;
        out.tip = true;
        if (chord.norm() > 1e-12) out.dir.head<3>() = chord.normalized();
        return out;
      }
      // A move of the orientation only: the rotary axes' combined rate (deg/min as mm/min).
    }
    for (int a_ = 0; a_ < gcode::kAxisCount; ++a_)
      if ((mask >> a_) & 1u) out.dir[a_] = b.c[a_] - a.c[a_];
    out.length = out.dir.norm();
    if (out.length > 0) out.dir /= out.length;
    return out;
  }

  void feed_move(const gcode::Block& b, const Motion& mo) {
    const int mi = map_for(b, mo);
    if (mi < 0) {
      end_run();
      return;
    }
    const machine::ProgramMap& map = p_.maps[static_cast<std::size_t>(mi)];
    const AxisMask need = machine::written_axes(m_, map.form());
    if ((mo.known & need) != need) {
      end_run();
      std::string names;
      int count = 0;
      for (int a = 0; a < gcode::kAxisCount; ++a)
        if (((need & ~mo.known) >> a) & 1u) {
          names += (count++ ? ", " : "") + std::string(1, gcode::kAxisLetters[static_cast<std::size_t>(a)]);
        }
      error(b, mo, kUnknownStart,
            fmt::format("the position of {} {} is not known at this feed move (no earlier block sets it), so its "
                        "path cannot be predicted; program {} before it",
                        count > 1 ? "axes" : "axis", names, names));
      note_position(mo);
      return;
    }
    if (!mo.feed_known || mo.feed <= 0 || mo.feed_mode == gcode::FeedMode::per_rev) {
      end_run();
      error(b, mo, kNoFeed,
            mo.feed_mode == gcode::FeedMode::per_rev
                ? std::string("feed per revolution (G95 / G99) needs the spindle speed over time, which prediction "
                              "does not model; program the cut in feed per minute")
                : std::string("this feed move has no feed rate (F); program F before it"));
      note_position(mo);
      return;
    }
    // The run's start: the end of the previous motion (the controller holds it).
    if (!in_run_) {
      machine::Command start{mo.start, last_vector_};
      if (!mo.tool_vector_known) start.vector = mo.tool_vector;
      kin::JointVector q;
      q_ = kin::JointVector::Zero(m_.nominal->joint_count());
      if (const kin::Solve s = map.joints(start, q_, q); !s.ok()) {
        error(b, mo, kKinematics, "the controller's inverse kinematics failed at the start of this move (" + map.explain(s) + ")");
        note_position(mo);
        return;
      }
      q_ = q;
      push_point(b, mo, mi, start, q, false, true, SegmentProfile{});
      run_begin_ = p_.points.size() - 1;
      in_run_ = true;
      prev_cmd_ = start;
    }
    const bool arc = mo.type != MotionType::linear;
    std::uint64_t n = 1;
    if (arc) {
      ++p_.arcs;
      const auto k = gcode::arc_segments(mo.arc.radius, mo.arc.sweep, opt_.arc_tolerance_mm, 0.0);
      n = k ? std::max<std::uint64_t>(*k, 2) : 2;
    } else if (opt_.densify_mm > 0) {
      const double len = metric(map, prev_cmd_, machine::Command{mo.end, mo.tool_vector}, need).length;
      n = static_cast<std::uint64_t>(std::clamp(std::ceil(len / opt_.densify_mm), 1.0, 1024.0));
    }
    const machine::Command from = prev_cmd_;
    for (std::uint64_t i = 1; i <= n; ++i) {
      const double f = static_cast<double>(i) / static_cast<double>(n);
      machine::Command c{arc ? gcode::arc_point(mo, f) : mo.end, mo.tool_vector};
      if (!arc && i < n) {  // an inner point of a densified move
        c.c = from.c + f * (mo.end - from.c);
        const Eigen::Vector3d v = from.vector + f * (mo.tool_vector - from.vector);
        if (v.norm() > 1e-12) c.vector = v.normalized();
      }
      if (i == n) c.c = mo.end;
      kin::JointVector q;
      if (const kin::Solve s = map.joints(c, q_, q); !s.ok()) {
        error(b, mo, kKinematics, "the controller's inverse kinematics failed for this move's end point (" + map.explain(s) + ")");
        end_run();
        note_position(mo);
        return;
      }
      add_point(b, mo, mi, c, q, i == n, arc || i < n);
    }
    ++p_.feed_moves;
    note_position(mo);
  }

  void add_point(const gcode::Block& b, const Motion& mo, int mi, const machine::Command& c, const kin::JointVector& q,
                 bool block_end, bool arc) {
    const machine::ProgramMap& map = p_.maps[static_cast<std::size_t>(mi)];
    const AxisMask need = machine::written_axes(m_, map.form());
    SegmentProfile s;
    const Metric mt = metric(map, prev_cmd_, c, need);
    s.length = mt.length;
    const kin::JointVector dq = q - q_;
    // Cruise speed: the programmed feed (inverse time: this chord's share of the block's time),
    // then every joint's velocity limit; the path acceleration from the joints' limits.
    double v = 0;
    if (mo.feed_mode == gcode::FeedMode::inverse_time) {
      double total =
          metric(map, machine::Command{mo.start, prev_cmd_.vector}, machine::Command{mo.end, mo.tool_vector}, need).length;
      if (mo.type != MotionType::linear && mo.arc.radius > 0)
        total = std::max(total, std::abs(mo.arc.sweep) * mo.arc.radius);
      const double block_time = 60.0 / mo.feed;
      v = total > 0 ? total / block_time : 0;
      if (v <= 0) v = s.length / block_time;
    } else {
      v = mo.feed / 60.0;
    }
    double accel = kUnlimited;
    for (int j = 0; j < q.size(); ++j) {
      const double d = std::abs(dq[j]);
      if (d <= 1e-12 || s.length <= 0) continue;
      const JointLimits& lim = limits_[static_cast<std::size_t>(j)];
      v = std::min(v, lim.v * s.length / d);
      accel = std::min(accel, lim.a * s.length / d);
    }
    s.v_cruise = v;
    s.accel = accel;
    push_point(b, mo, mi, c, q, block_end && !arc, false, s);
    metric_.back() = mt;
    q_ = q;
    prev_cmd_ = c;
  }

  /// A point of the block's motion (the block's single motion is the last one counted) with the
  /// profile of the segment ending there.
  void push_point(const gcode::Block& b, const Motion& mo, int mi, const machine::Command& c, const kin::JointVector& q,
                  bool block_end, bool run_start, const SegmentProfile& s) {
    PathPoint p;
    p.q = q;
    p.command = c;
    p.line = b.line;
    p.column = mo.column;
    p.motion = static_cast<std::uint32_t>(p_.motions - 1);
    p.map = static_cast<std::uint32_t>(mi);
    p.block_end = block_end;
    p.run_start = run_start;
    p_.points.push_back(p);
    p_.segments.push_back(s);
    metric_.emplace_back();
    blend_at_.push_back(blend_);
  }

  /// Look-ahead over the finished run: junction speeds (corner slow-down), backward and forward
  /// acceleration passes, then every segment's trapezoid and the point times.
  void end_run() {
    if (!in_run_) return;
    in_run_ = false;
    const std::size_t b = run_begin_, e = p_.points.size();
    if (e - b < 2) {  // a run without a move
      p_.points.resize(b);
      p_.segments.resize(b);
      metric_.resize(b);
      blend_at_.resize(b);
      return;
    }
    const std::size_t n = e - b;
    std::vector<double> vj(n, 0.0);  // speed at each point
    auto dir = [&](std::size_t i) -> kin::JointVector {  // dq/ds of segment i (ending at point i)
      const double L = p_.segments[i].length;
      kin::JointVector d = p_.points[i].q - p_.points[i - 1].q;
      return L > 0 ? kin::JointVector(d / L) : kin::JointVector(d * 0.0);
    };
    // A move of zero length (a block that repeats the point) is passed through, not a stop: the
    // junction around it joins the moves on either side of it (as LinuxCNC's planner drops such
    // a segment), with both its ends at that speed. None on one side: the run starts or ends there.
    const auto moving = [&](std::size_t i, std::ptrdiff_t step) -> std::size_t {  // 0: none
      for (; i > b && i < e; i = static_cast<std::size_t>(static_cast<std::ptrdiff_t>(i) + step))
        if (p_.segments[i].length > 0) return i;
      return 0;
    };
    for (std::size_t k = 1; k + 1 < n; ++k) {
      const std::size_t i = b + k, s1 = moving(i, -1), s2 = moving(i + 1, 1);
      if (s1 == 0 || s2 == 0) continue;  // vj[k] stays 0
      const double v = std::min(p_.segments[s1].v_cruise, p_.segments[s2].v_cruise);
      vj[k] = std::min(v, corner_speed(i, s1, s2, dir(s1), dir(s2)));
    }
    for (std::size_t k = n - 1; k-- > 1;) {  // backward: able to slow down in time
      const SegmentProfile& s = p_.segments[b + k + 1];
      vj[k] = std::min(vj[k], std::sqrt(vj[k + 1] * vj[k + 1] + 2 * s.accel * s.length));
    }
    for (std::size_t k = 1; k < n; ++k) {  // forward: able to speed up in time
      const SegmentProfile& s = p_.segments[b + k];
      vj[k] = std::min(vj[k], std::sqrt(vj[k - 1] * vj[k - 1] + 2 * s.accel * s.length));
    }
    double t = p_.duration;
    p_.points[b].t = t;
    p_.points[b].speed = 0;
    for (std::size_t k = 1; k < n; ++k) {
      SegmentProfile& s = p_.segments[b + k];
      s.v_start = std::min(vj[k - 1], s.v_cruise);
      s.v_end = std::min(vj[k], s.v_cruise);
      double peak = 0;
      s.duration = s.v_cruise > 0 ? trapezoid(s.length, s.v_start, s.v_end, s.v_cruise, s.accel, peak) : 0;
      s.v_cruise = peak;
      t += s.duration;
      p_.points[b + k].t = t;
      p_.points[b + k].speed = vj[k];
    }
    p_.duration = t;
    p_.runs.push_back(Run{b, e});
  }

  /// The highest speed through the junction at point i (between the moving segments s1 before
  /// and s2 after it, joint directions d1, d2 = dq/ds) that the corner rule in force at i allows
  /// (docs/contour.md "Corners").
  double corner_speed(std::size_t i, std::size_t s1, std::size_t s2, const kin::JointVector& d1,
                      const kin::JointVector& d2) const {
    const Blend& bl = blend_at_[i];
    const Metric& m1 = metric_[s1];
    const Metric& m2 = metric_[s2];
    double v = std::numeric_limits<double>::infinity();
    if (bl.rule != machine::CornerRule::time && m1.tip == m2.tip && m1.length > 0 && m2.length > 0) {
      // A circular blend in the feed metric's space, tangent to both moves: radius R from the
      // tolerance (deviation at the corner) or the blend distance, at most half of either move.
      const double cos_t = std::clamp(m1.dir.dot(m2.dir), -1.0, 1.0);
      const double theta = std::acos(cos_t);  // turn angle
      if (theta < 1e-9) return v;
      const double half = theta / 2;
      if (std::cos(half) < 1e-12) return 0.0;  // reversal
      double R = bl.rule == machine::CornerRule::tolerance ? bl.value * std::cos(half) / (1 - std::cos(half))
                                                           : bl.value / std::tan(half);
      R = std::min(R, 0.5 * std::min(m1.length, m2.length) / std::tan(half));
      // Joint j along the blend: q̈_j = v²/R·(−sin α·d1_j + cos α·e2_j), d⃛q_j = v³/R²·(−cos α·d1_j − sin α·e2_j),
      // α ∈ [0, θ], e2 the joints' image of the blend plane's unit normal to the first move.
      const kin::JointVector e2 = (d2 - d1 * cos_t) / std::sin(theta);
      for (int j = 0; j < d1.size(); ++j) {
        const JointLimits& lim = limits_[static_cast<std::size_t>(j)];
        if (std::isfinite(lim.a)) {
          const double peak = sinusoid_peak(-d1[j], e2[j], theta);
          if (peak > 1e-12) v = std::min(v, std::sqrt(lim.a * R / peak));
        }
        if (std::isfinite(lim.j)) {
          const double peak = sinusoid_peak(-e2[j], -d1[j], theta);
          if (peak > 1e-12) v = std::min(v, std::cbrt(lim.j * R * R / peak));
        }
      }
      return v;
    }
    // Corner time: every joint's velocity jump at most max_acceleration · corner_time.
    const double t = bl.rule == machine::CornerRule::time ? bl.value : m_.interpolator.corner_time;
    const kin::JointVector jump = d2 - d1;
    for (int j = 0; j < jump.size(); ++j) {
      const double a = limits_[static_cast<std::size_t>(j)].a;
      if (std::isfinite(a) && std::abs(jump[j]) > 1e-12) v = std::min(v, a * t / std::abs(jump[j]));
    }
    return v;
  }

  /// The machine file's corner rule.
  [[nodiscard]] Blend machine_blend() const {
    const machine::InterpolatorSettings& s = m_.interpolator;
    return s.corner == machine::CornerRule::tolerance ? Blend{s.corner, s.corner_tolerance}
                                                      : Blend{machine::CornerRule::time, s.corner_time};
  }

  /// The program's blending words: LinuxCNC G64 [P<tol>], Siemens G64 / G641 ADIS= / G642 G643
  /// G645 [CTOL=]; other path-control codes (Fanuc G64, …) return to the machine file's rule.
  void update_blend(const gcode::Block& b) {
    const bool siemens = d_.id == gcode::DialectId::siemens;
    const double unit = track_.inch ? 25.4 : 1.0;
    if (siemens)
      for (const gcode::Token& t : b.tokens) {
        if (t.kind != gcode::TokenKind::assignment) continue;
        const std::string_view span = b.text(t.span);
        const auto eq = span.find('=');
        if (eq == std::string_view::npos) continue;
        std::string_view value = span.substr(eq + 1);
        while (!value.empty() && (value.front() == ' ' || value.front() == '\t')) value.remove_prefix(1);
        while (!value.empty() && (value.back() == ' ' || value.back() == '\t')) value.remove_suffix(1);
        double v = 0;
        if (!gcode::parse_number(value, v)) continue;
        const std::string name = gcode::text::upper(b.text(t.name));
        if (name == "ADIS") adis_ = v * unit;
        if (name == "CTOL") ctol_ = v * unit;  // negative: back to the machine data
      }
    if (const auto* g = track_.find(gcode::GMeaning::path_control)) {
      if (siemens) siemens_code_ = g->def->code10;
      blend_from_g(b, *g);
    } else if (siemens && siemens_code_ != 0) {
      blend_from_siemens();  // ADIS= / CTOL= alone
    }
  }

  void blend_from_g(const gcode::Block& b, const gcode::ModalTrack::G& g) {
    const std::uint16_t code = g.def->code10;
    if (d_.id == gcode::DialectId::linuxcnc && code == 640) {
      // G64 P<tol>: blend within tol; G64 (or P0): best possible speed, the corner-time rule.
      double p = 0;
      for (const gcode::Word& w : b.words)
        if (w.letter == 'P' && gcode::plain_letter(w) && w.kind == gcode::ValueKind::number) p = w.number;
      blend_ = p > 0 ? Blend{machine::CornerRule::tolerance, p * (track_.inch ? 25.4 : 1.0)}
                     : Blend{machine::CornerRule::time, m_.interpolator.corner_time};
      return;
    }
    if (d_.id == gcode::DialectId::siemens) {
      blend_from_siemens();
      return;
    }
    blend_ = machine_blend();
  }

  void blend_from_siemens() {
    switch (siemens_code_) {
      case 640: blend_ = Blend{machine::CornerRule::time, m_.interpolator.corner_time}; break;
      case 6410:  // rounding over ADIS before and after the corner; ADIS=0 rounds nothing (as G64)
        blend_ = adis_ > 0 ? Blend{machine::CornerRule::distance, adis_}
                           : Blend{machine::CornerRule::time, m_.interpolator.corner_time};
        break;
      case 6420: case 6430: case 6450:
        blend_ = Blend{machine::CornerRule::tolerance, ctol_ > 0 ? ctol_ : m_.interpolator.corner_tolerance};
        break;
      default: blend_ = machine_blend(); break;
    }
  }

  std::string_view file_;
  const machine::Machine& m_;
  const PathOptions& opt_;
  gcode::DiagnosticSink& sink_;
  Path& p_;
  gcode::ModalTrack track_;
  machine::ToolLengthModels models_;
  std::vector<JointLimits> limits_;
  gcode::DiagnosticSink collect_{0};
  bool in_run_ = false;
  bool exact_mode_ = false;  ///< G61 / G60 active
  const gcode::Dialect& d_;
  Blend blend_;                    ///< the corner rule in force
  std::vector<Blend> blend_at_;    ///< per point: the rule for the junction at its end
  std::vector<Metric> metric_;     ///< per point: the feed metric of the segment ending there
  double adis_ = 0;                ///< Siemens ADIS=, mm
  double ctol_ = -1;               ///< Siemens CTOL=, mm (< 0: the machine file's tolerance)
  std::uint16_t siemens_code_ = 0; ///< the Siemens path-control code in force (code10: 640, 6410, …), 0 before any
  std::size_t run_begin_ = 0;
  kin::JointVector q_;
  machine::Command prev_cmd_;
  Eigen::Vector3d last_vector_ = Eigen::Vector3d::UnitZ();
  machine::ModalToolVector vector_{m_};
  int map_index_ = -1;
  machine::Form key_form_ = machine::Form::axes;
  gcode::AxisVector key_offset_ = gcode::AxisVector::Zero();
  bool key_on_z_ = false;
  double key_length_ = 0;
};

}  // namespace

std::optional<std::vector<Drive>> joint_drives(const machine::Machine& m, std::string& why) {
  std::vector<Drive> out;
  for (const kin::Joint& j : m.actual->joints()) {
    const machine::AxisSettings* s = settings_of(m, j.name);
    const auto d = s != nullptr ? drive_of(*s) : std::nullopt;
    if (!d) {
      const bool axis = j.name.size() == 1 && gcode::axis_index(j.name[0]) >= 0;
      why = fmt::format("joint {} has no servo data: add kv (position-loop gain, e.g. kv = \"30 1/s\") to [{}.{}] in "
                        "machine file {}",
                        j.name, axis ? "axes" : "drives", j.name, m.file);
      return std::nullopt;
    }
    out.push_back(*d);
  }
  return out;
}

namespace {

/// build_path with `run` driving the interpreter over the builder (visitor, its sink).
template <class RunProgram>
Path build_path_with(std::string_view file, const gcode::Dialect& d, const machine::Machine& m, const PathOptions& opt,
                     gcode::DiagnosticSink& sink, RunProgram&& run) {
  Path path;
  path.joints = m.actual->joint_count();
  path.period = m.interpolation_period;
  path.combined_feed = m.feed == machine::FeedReference::combined_axes;
  std::string why;
  if (auto drives = joint_drives(m, why)) {
    path.drives = std::move(*drives);
  } else {
    gcode::Diagnostic diag;
    diag.severity = gcode::Severity::error;
    diag.code = "PP-E611";
    diag.file = m.file;
    diag.message = why;
    locate_table(m, why, diag);
    sink.report(diag);
    path.drives.assign(static_cast<std::size_t>(path.joints), Drive{});
  }
  std::vector<JointLimits> limits;
  for (const kin::Joint& j : m.actual->joints()) {
    JointLimits l;
    if (const machine::AxisSettings* s = settings_of(m, j.name)) {
      if (s->max_velocity) l.v = *s->max_velocity / 60.0;
      if (s->max_acceleration) l.a = *s->max_acceleration;
      if (s->max_jerk) l.j = *s->max_jerk;
    }
    limits.push_back(l);
    path.jerk_window.push_back(std::isfinite(l.a) && std::isfinite(l.j) ? l.a / l.j : 0.0);
  }
  Builder b(file, d, m, opt, sink, path, std::move(limits));
  run(b.collector(), b);
  b.finish();
  return path;
}

}  // namespace

Path build_path(gcode::LineReader& in, std::string_view file, const gcode::Dialect& d, const machine::Machine& m,
                const PathOptions& opt, gcode::DiagnosticSink& sink) {
  return build_path_with(file, d, m, opt, sink, [&](gcode::DiagnosticSink& s, gcode::BlockVisitor& v) {
    gcode::run_program(in, d, file, s, v);
  });
}

Path build_path(std::string_view text, std::string_view file, const gcode::Dialect& d, const machine::Machine& m,
                const PathOptions& opt, gcode::DiagnosticSink& sink, const gcode::ResolveOptions& resolve) {
  return build_path_with(file, d, m, opt, sink, [&](gcode::DiagnosticSink& s, gcode::BlockVisitor& v) {
    gcode::run_program_text(text, d, file, s, v, resolve);
  });
}

void interpolate(const Path& path, const Run& run, double settle, const std::function<void(const Sample&)>& visit) {
  if (run.size() < 2) return;
  const double t0 = path.points[run.begin].t;
  const double t_end = path.points[run.end - 1].t;
  const double dt = path.period;
  std::size_t seg = run.begin + 1;
  Sample s;
  kin::JointVector q_prev = path.points[run.begin].q;
  // Jerk: a moving average over window[j] samples per joint (1: none), seeded with the start point.
  const auto nj = static_cast<std::size_t>(q_prev.size());
  std::vector<std::size_t> window(nj, 1);
  std::size_t longest = 1;
  for (std::size_t j = 0; j < nj && j < path.jerk_window.size(); ++j) {
    window[j] = std::max<std::size_t>(1, static_cast<std::size_t>(std::llround(path.jerk_window[j] / dt)));
    longest = std::max(longest, window[j]);
  }
  std::vector<kin::JointVector> raw(longest, q_prev);  // ring of the last raw samples
  kin::JointVector sum(q_prev.size());
  for (std::size_t j = 0; j < nj; ++j) sum[static_cast<Eigen::Index>(j)] = q_prev[static_cast<Eigen::Index>(j)] * static_cast<double>(window[j]);
  // The last period of the move lands on the end point (the averaged command `longest` − 1
  // periods later); then `settle` seconds at rest.
  const auto total = static_cast<std::uint64_t>(std::ceil((t_end - t0) / dt - 1e-9) + std::floor(settle / dt + 1e-9)) +
                     (longest - 1);
  for (std::uint64_t k = 0; k <= total; ++k) {
    const double t = t0 + static_cast<double>(k) * dt;
    while (seg + 1 < run.end && path.points[seg].t < t) ++seg;
    const PathPoint& a = path.points[seg - 1];
    const PathPoint& b = path.points[seg];
    const SegmentProfile& prof = path.segments[seg];
    double f = 1.0;
    if (t < b.t && prof.length > 0) f = std::clamp(position_at(prof, t - a.t) / prof.length, 0.0, 1.0);
    else if (t < b.t && prof.duration > 0) f = std::clamp((t - a.t) / prof.duration, 0.0, 1.0);
    const machine::ProgramMap& map = path.maps[b.map];
    s.t = t;
    s.segment = seg;
    s.fraction = f;
    if (map.form() == machine::Form::axes || f <= 0.0 || f >= 1.0) {
      s.q = f >= 1.0 ? b.q : (f <= 0.0 ? a.q : kin::JointVector(a.q + (b.q - a.q) * f));
    } else {
      machine::Command c;
      c.c = a.command.c + (b.command.c - a.command.c) * f;
      c.vector = (a.command.vector + (b.command.vector - a.command.vector) * f).normalized();
      kin::JointVector q;
      if (map.joints(c, q_prev, q).ok()) s.q = q;
      else s.q = a.q + (b.q - a.q) * f;
    }
    q_prev = s.q;
    if (longest > 1) {
      const std::size_t slot = static_cast<std::size_t>(k % longest);
      for (std::size_t j = 0; j < nj; ++j) {
        const auto ej = static_cast<Eigen::Index>(j);
        // The sample leaving joint j's window is window[j] samples old.
        const std::size_t old = (slot + longest - window[j]) % longest;
        const double leaving = k >= window[j] ? raw[old][ej] : path.points[run.begin].q[ej];
        sum[ej] += s.q[ej] - leaving;
      }
      raw[slot] = s.q;
      for (std::size_t j = 0; j < nj; ++j) {
        const auto ej = static_cast<Eigen::Index>(j);
        if (window[j] > 1) s.q[ej] = sum[ej] / static_cast<double>(window[j]);
      }
    }
    visit(s);
  }
}

}  // namespace postproc::contour
