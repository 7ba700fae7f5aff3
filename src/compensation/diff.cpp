// postproc diff: the motions of two programs paired by block or by path, their axis deltas and
// (with a machine) the distance between their intended tool poses.
#include "postproc/compensation/diff.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "postproc/gcode/program.hpp"
#include "src/compensation/compensate_support.hpp"

namespace postproc::comp {
namespace {

std::vector<const CollectedMotion*> motions_of(std::string_view text, std::string_view file, const gcode::Dialect& d,
                                               const gcode::ResolveOptions& resolve, gcode::DiagnosticSink& sink,
                                               MotionCollector& c) {
  std::vector<const CollectedMotion*> out;
  if (gcode::needs_resolution(text, d)) {
    // Collected per resolved line (each execution once, in order), then named by source line.
    const std::size_t errors = sink.count(gcode::Severity::error);
    const gcode::ResolvedProgram r = gcode::resolve(text, file, d, gcode::with_program_folder(resolve, file), sink);
    if (sink.count(gcode::Severity::error) > errors) return out;
    gcode::DiagnosticSink mapped = gcode::source_mapped(r, sink);
    gcode::LineReader in{std::string_view(r.text)};
    gcode::InterpreterOptions opt;
    opt.source_text = false;  // the resolver checked the source lines
    gcode::run_program(in, d, file, mapped, c, opt);
    for (auto& [line, m] : c.by_line)
      if (line >= 1 && line <= r.source_line.size()) m.motion.line = r.source_line[line - 1];
  } else {
    gcode::LineReader in{text};
    gcode::run_program(in, d, file, sink, c);
  }
  out.reserve(c.by_line.size());
  for (const auto& [line, m] : c.by_line) out.push_back(&m);
  return out;
}

double end_distance(const gcode::Motion& a, const gcode::Motion& b) {
  const gcode::AxisMask both = a.known & b.known;
  double s = 0;
  for (int k = 0; k < gcode::kAxisCount; ++k)
    if ((both >> k) & 1u) s += (a.end[k] - b.end[k]) * (a.end[k] - b.end[k]);
  return std::sqrt(s);
}

/// How far past the best candidate the by-path search looks before it stops, in motions (a
/// subdivided move or a linearised arc adds at most 4096 lines).
constexpr std::size_t kLookAhead = 4200;

}  // namespace

DiffResult diff(std::string_view original, std::string_view corrected, std::string_view file_original,
                std::string_view file_corrected, const gcode::Dialect& d, const machine::Machine* m,
                gcode::DiagnosticSink& sink, const gcode::ResolveOptions& resolve) {
  MotionCollector ca(d), cb(d);
  const auto a = motions_of(original, file_original, d, resolve, sink, ca);
  const auto b = motions_of(corrected, file_corrected, d, resolve, sink, cb);
  DiffResult r;
  r.motions_original = a.size();
  r.motions_corrected = b.size();
  r.by_block = a.size() == b.size();
  r.with_machine = m != nullptr;
  // The linear axes the original writes somewhere: a point is known once all of them are.
  constexpr gcode::AxisMask kXyz = 0b111;
  gcode::AxisMask used = 0;
  for (const CollectedMotion* c : a) used = static_cast<gcode::AxisMask>(used | (c->motion.known & kXyz));
  std::optional<ToolLengthModels> models;
  if (m != nullptr) models.emplace(*m);
  kin::JointVector start;
  if (m != nullptr) start = kin::JointVector::Zero(m->nominal->joint_count());
  std::vector<double> dev, ang;
  std::size_t next = 0;  // first corrected motion not yet paired
  for (std::size_t i = 0; i < a.size(); ++i) {
    const gcode::Motion& ma = a[i]->motion;
    std::size_t j = i;
    if (!r.by_block) {
      // By path: the nearest end point among the following corrected motions.
      if (next >= b.size()) {
        ++r.unmatched;
        continue;
      }
      j = next;
      double best = end_distance(ma, b[next]->motion);
      for (std::size_t k = next + 1; k < b.size() && k < j + kLookAhead; ++k) {
        const double dk = end_distance(ma, b[k]->motion);
        if (dk < best) {
          best = dk;
          j = k;
        }
      }
    }
    next = j + 1;
    const gcode::Motion& mb = b[j]->motion;
    BlockDiff bd;
    bd.line_original = ma.line;
    bd.line_corrected = mb.line;
    bd.axes = static_cast<gcode::AxisMask>(ma.known & mb.known);
    double lin = 0;
    for (int k = 0; k < gcode::kAxisCount; ++k) {
      if (!((bd.axes >> k) & 1u)) continue;
      bd.delta[k] = mb.end[k] - ma.end[k];
      if (gcode::is_rotary(k)) bd.rotary_deg = std::max(bd.rotary_deg, std::abs(bd.delta[k]));
      else lin += bd.delta[k] * bd.delta[k];
    }
    bd.linear_mm = std::sqrt(lin);
    bd.deviation_mm = bd.linear_mm;
    if (m == nullptr && used != 0 && (ma.known & used) == used) {
      for (int k = 0; k < 3; ++k) bd.point_mm[k] = ((used >> k) & 1u) ? ma.end[k] : 0.0;
      bd.point_known = true;
    }
    if (bd.linear_mm > 1e-9 || bd.rotary_deg > 1e-9) ++r.changed;
    if (m != nullptr && !a[i]->reference && !b[j]->reference) {
      const auto map_a = map_of(*m, *models, ma);
      const auto map_b = map_of(*m, *models, mb);
      const gcode::AxisMask need_a = map_a ? written_axes(*m, map_a->form()) : 0;
      const gcode::AxisMask need_b = map_b ? written_axes(*m, map_b->form()) : 0;
      kin::Pose pa, pb;
      kin::JointVector qa, qb;
      if (map_a && map_b && (ma.known & need_a) == need_a && (mb.known & need_b) == need_b &&
          map_a->intended(Command{ma.end, ma.tool_vector}, start, pa, qa).ok() &&
          map_b->intended(Command{mb.end, mb.tool_vector}, start, pb, qb).ok()) {
        bd.tip_mm = (pb.p - pa.p).norm();
        bd.axis_rad = kin::angle_between(pa.axis(), pb.axis());
        bd.deviation_mm = bd.tip_mm;
        bd.point_mm = pa.p;
        bd.point_known = true;
        start = qa;
      }
    }
    if (m != nullptr) ang.push_back(std::isnan(bd.axis_rad) ? 0.0 : bd.axis_rad);
    dev.push_back(bd.deviation_mm);
    r.blocks.push_back(bd);
  }
  r.deviation = contour::summarise(dev);
  r.angle = contour::summarise(ang);
  return r;
}

std::vector<std::size_t> worst_blocks(const DiffResult& r, std::size_t n) {
  std::vector<std::size_t> idx(r.blocks.size());
  std::iota(idx.begin(), idx.end(), 0);
  n = std::min(n, idx.size());
  std::partial_sort(idx.begin(), idx.begin() + static_cast<std::ptrdiff_t>(n), idx.end(), [&](std::size_t x, std::size_t y) {
    return r.blocks[x].deviation_mm > r.blocks[y].deviation_mm ||
           (r.blocks[x].deviation_mm == r.blocks[y].deviation_mm && x < y);
  });
  idx.resize(n);
  return idx;
}

}  // namespace postproc::comp
