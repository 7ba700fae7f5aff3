// compensate: a block before every axis is known (a first rapid that gives only Z, a program that
// starts in G55 without X Y). The controller moves only the axes a block names; the others stay
// where it holds them, which the program does not say. The correction is accepted when it does not
// depend on where they stand, checked at positions the controller can hold (their travel ends), and
// the report's figures are the worst over those positions, never computed from an assumed 0.
#include "src/compensation/compensator.hpp"

namespace postproc::comp::detail {
namespace {

/// Joint-less program axes (a parallel machine's tool tip and virtual angles): samples around the
/// home pose's value, mm / deg.
constexpr double kToolTipSpanMm = 100;
constexpr double kToolTipSpanDeg = 30;
/// A command the controller can hold maps back onto itself through its joints.
constexpr double kRoundTrip = 1e-6;

}  // namespace

std::vector<double> Compensator::unknown_samples(const ProgramMap& map, const Command& cmd, int a) const {
  for (int j = 0; j < map.nominal().joint_count(); ++j) {
    if (map.axis_of_joint(j) != a) continue;
    // The joint at each end of its travel, in the program's coordinates (work offset, tool length,
    // for tool-tip forms the tool tip there); an unlimited axis at 0 and half a turn.
    const kin::Joint& jt = map.nominal().joints()[static_cast<std::size_t>(j)];
    std::vector<double> v;
    for (const double end : {std::isfinite(jt.min) ? jt.min : 0.0, std::isfinite(jt.max) ? jt.max : 180.0}) {
      kin::JointVector q = joints_;
      q[j] = end;
      Command c;
      if (map.command(q, cmd, c).ok()) v.push_back(c.c[a]);
    }
    return v;
  }
  Command home;
  const double centre = map.command(joints_, cmd, home).ok() ? home.c[a] : 0.0;
  const double span = gcode::is_rotary(a) ? kToolTipSpanDeg : kToolTipSpanMm;
  return {centre - span, centre + span};
}

bool Compensator::reachable(const ProgramMap& map, const Command& c) const {
  kin::Pose p;
  kin::JointVector q;
  Command back;
  if (!map.intended(c, joints_, p, q).ok() || !map.command(q, c, back).ok()) return false;
  for (int j = 0; j < map.nominal().joint_count(); ++j) {
    // Joints that are not program axes (struts, sliders) must be inside their travel; the program
    // axes' own travel is checked on the known ones after the correction.
    const kin::Joint& jt = map.nominal().joints()[static_cast<std::size_t>(j)];
    if (map.axis_of_joint(j) < 0 && (q[j] < jt.min || q[j] > jt.max)) return false;
  }
  for (int a = 0; a < gcode::kAxisCount; ++a)
    if (((mask_ >> a) & 1u) && !(std::abs(back.c[a] - c.c[a]) <= kRoundTrip)) return false;
  return map.form() != Form::tcp_vector || (back.vector - c.vector.normalized()).norm() <= kRoundTrip;
}

bool Compensator::invariant(const Block& b, const Motion& m, const ProgramMap& map, const Command& cmd,
                            AxisMask unknown, Command& out, kin::JointVector& q, bool figures) {
  std::vector<int> axes;
  std::vector<std::vector<double>> samples;
  std::size_t combos = 1;
  for (int a = 0; a < gcode::kAxisCount; ++a)
    if ((unknown >> a) & 1u) {
      axes.push_back(a);
      samples.push_back(unknown_samples(map, cmd, a));
      combos *= samples.back().size();
    }
  std::string names;
  for (const int a : axes) names += gcode::kAxisLetters[static_cast<std::size_t>(a)];
  std::optional<Command> first;
  std::vector<Command> checked;  // the sample commands the correction was checked at
  std::string why;
  for (std::size_t combo = 0; combo < combos && why.empty(); ++combo) {
    Command c = cmd;
    for (std::size_t i = 0, k = combo; i < axes.size(); k /= samples[i].size(), ++i)
      c.c[axes[i]] = samples[i][k % samples[i].size()];
    // A position the controller cannot hold says nothing about this block.
    if (!reachable(map, c)) continue;
    Command o;
    kin::JointVector qq;
    if (!map.correct(c, joints_, o, qq).ok()) continue;
    for (int a = 0; a < gcode::kAxisCount && why.empty(); ++a) {
      if (!((mask_ >> a) & 1u)) continue;
      const bool depends = ((unknown >> a) & 1u) ? rounded_change(a, c.c[a], o.c[a], m)
                                                 : first && rounded_change(a, first->c[a], o.c[a], m);
      if (depends) why = "the correction of this move depends on it";
    }
    if (!why.empty()) break;
    if (!first) {
      first = o;
      q = qq;
    }
    checked.push_back(c);
  }
  if (why.empty() && !first)
    why = fmt::format("the correction cannot be checked at any position of axis {} the machine can hold", names);
  if (!why.empty()) {
    if (m.type == MotionType::rapid) {
      // A positioning move before every axis is known: it cuts nothing, so it stays as written; the
      // controller then holds the uncorrected values, which the next moves (tracked through
      // written_) take into account.
      note(b, m.column, kRapidAsWritten,
           fmt::format("rapid move left as written: the position of axis {} is not known here and {}; the "
                       "following moves are corrected",
                       names, why));
      ++r_.rapids_as_written;
      rapid_as_written_ = true;
      return false;
    }
    refuse(b, m.column, kRefused,
           fmt::format("the position of axis {} is not known here (no earlier block sets it) and {}; program {} "
                       "before this move",
                       names, why, names));
    return false;
  }
  if (figures) {
    measured_block_ = &b;
    // The worst over the checked positions: each one's error before and residual after.
    for (const Command& c : checked) {
      Command o;
      kin::JointVector qq;
      if (!map.correct(c, joints_, o, qq).ok()) continue;
      for (const int a : axes) o.c[a] = c.c[a];
      measure(m, c, map, o, qq, unknown);
    }
  }
  out = *first;
  for (const int a : axes) out.c[a] = cmd.c[a];
  return true;
}

}  // namespace postproc::comp::detail
