// Checks a compensated program: the corrected end points on the actual machine against the
// original end points on the nominal machine, within the rounding of the written words.
#include "postproc/compensation/verify.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include "postproc/machine/program_map.hpp"
#include "postproc/gcode/program.hpp"
#include "src/compensation/compensate_support.hpp"

namespace postproc::comp {

VerifyResult verify(std::string_view original, std::string_view corrected, const std::vector<std::uint64_t>& line_map,
                    const gcode::Dialect& d, const machine::Machine& m, std::vector<VerifyPoint>* points) {
  MotionCollector orig(d), corr(d);
  gcode::DiagnosticSink quiet(0);
  {
    gcode::LineReader r{original};
    gcode::run_program(r, d, "original", quiet, orig);
  }
  {
    gcode::LineReader r{corrected};
    gcode::run_program(r, d, "corrected", quiet, corr);
  }
  // Original line → the last corrected motion among the lines that came from it.
  std::map<std::uint64_t, const CollectedMotion*> last;
  for (const auto& [line, c] : corr.by_line)
    if (line >= 1 && line <= line_map.size() && line_map[line - 1] != 0) last[line_map[line - 1]] = &c;

  VerifyResult v;
  ToolLengthModels models(m);
  kin::JointVector start = kin::JointVector::Zero(m.nominal->joint_count());
  for (const auto& [line, o] : orig.by_line) {
    const auto it = last.find(line);
    const gcode::Motion& mo = o.motion;
    if (o.reference || it == last.end() || mo.type == gcode::MotionType::drill_cycle) {
      ++v.skipped;
      continue;
    }
    const gcode::Motion& mc = it->second->motion;
    const Form f = form_of(m, mo);
    const gcode::AxisMask need = written_axes(m, f);
    if ((mo.known & need) != need || (mc.known & need) != need ||
        (mo.type == gcode::MotionType::rapid && (mo.end - mc.end).cwiseAbs().maxCoeff() == 0)) {
      ++v.skipped;  // unknown positions, or a rapid left as written
      continue;
    }
    auto map_o = map_of(m, models, mo);
    auto map_c = map_of(m, models, mc);
    if (!map_o || !map_c) {
      ++v.skipped;
      continue;
    }
    kin::Pose want, got;
    kin::JointVector q1, q2;
    if (!map_o->intended(Command{mo.end, mo.tool_vector}, start, want, q1).ok() ||
        !map_c->real(Command{mc.end, mc.tool_vector}, start, got, q2).ok()) {
      ++v.skipped;
      continue;
    }
    kin::Pose before;
    kin::JointVector q3;
    double before_mm = std::numeric_limits<double>::quiet_NaN(), before_rad = before_mm;
    if (map_o->real(Command{mo.end, mo.tool_vector}, start, before, q3).ok()) {
      before_mm = (before.p - want.p).norm();
      before_rad = kin::angle_between(before.axis(), want.axis());
      v.max_error_before_mm = std::max(v.max_error_before_mm, before_mm);
      v.max_error_before_rad = std::max(v.max_error_before_rad, before_rad);
    }
    // The rounding bound: half a unit of each written axis, carried to the tool tip.
    const double bound = rounding_bound(m, *map_c, mc, need, f, start, got).tip_mm;
    const double err = (got.p - want.p).norm();
    const double ang = kin::angle_between(got.axis(), want.axis());
    ++v.compared;
    v.max_error_mm = std::max(v.max_error_mm, err);
    v.max_error_rad = std::max(v.max_error_rad, ang);
    v.max_bound_mm = std::max(v.max_bound_mm, bound);
    if (points != nullptr) points->push_back({line, want.p, before_mm, before_rad, err, ang, bound});
    if (v.compared == 1 || err - bound > v.max_excess_mm) {
      v.max_excess_mm = err - bound;
      v.worst_line = line;
    }
    start = q2;
  }
  return v;
}

}  // namespace postproc::comp
