// compensate --mode contour: the program's commanded path, its predicted servo contour errors,
// the precompensated commands, and the program written with the corrected end points.
#include <fmt/format.h>

#include "postproc/compensation/compensate.hpp"
#include "postproc/gcode/block_writer.hpp"
#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/program.hpp"
#include "src/compensation/compensate_support.hpp"
#include "src/gcode/convert_support.hpp"

namespace postproc::comp {
namespace {

/// Second pass: the blocks as read, with the corrected end points written into their words.
class ContourWriter final : public gcode::BlockVisitor {
 public:
  ContourWriter(std::string_view file, const gcode::Dialect& d, const machine::Machine& m, const CompensateOptions& opt,
                const contour::Path& path, const std::vector<kin::JointVector>& commands, io::OutputFile& out,
                gcode::DiagnosticSink& sink, CompensateResult& r)
      : file_(file), d_(d), m_(m), opt_(opt), path_(path), commands_(commands), out_(out), sink_(sink), r_(r),
        track_(d) {
    point_of_motion_.assign(path.motions, -1);
    for (std::size_t i = 0; i < path.points.size(); ++i) {
      const contour::PathPoint& p = path.points[i];
      if (p.block_end && !p.run_start && p.motion < point_of_motion_.size())
        point_of_motion_[p.motion] = static_cast<std::int64_t>(i);
    }
    written_.setZero();
  }

  void block(const gcode::Block& b, std::span<const gcode::Motion> motions, bool lexed_ok) override {
    ++r_.blocks;
    if (!b.eol.empty()) eol_ = std::string(b.eol);
    if (!header_done_ && opt_.header && !header_waits(b)) {
      header_done_ = true;
      emit(header_comment(d_, m_, opt_), eol_, 0);
    }
    track_.update(b);
    gcode::BlockEditor ed(b, d_.decimal_point_required);
    if (lexed_ok) {
      for (const gcode::Motion& mo : motions) {
        ++r_.motions;
        const std::uint64_t k = motion_++;
        const std::int64_t pi = k < point_of_motion_.size() ? point_of_motion_[k] : -1;
        if (motions.size() == 1 && pi >= 0) {
          correct(b, mo, static_cast<std::size_t>(pi), ed);
        } else {
          written_ = mo.end;
          written_known_ = mo.known;
          if ((mo.type == gcode::MotionType::arc_cw || mo.type == gcode::MotionType::arc_ccw) && !arc_noted_) {
            arc_noted_ = true;
            const gcode::Span sp{mo.column > 0 ? mo.column - 1 : 0, mo.column > 0 ? mo.column : 1};
            gcode::report_at(gcode::LexContext{file_, &sink_}, b, sp, gcode::Severity::warning, "PP-W611",
                             "arcs are predicted (as chords) but written as they are, without contour correction; "
                             "linearise them first (postproc convert --linearize TOL) to have them corrected");
          }
        }
      }
      if (track_.has(gcode::GMeaning::home_return) || track_.has(gcode::GMeaning::work_offset) ||
          track_.has(gcode::GMeaning::set_offsets_g10))
        written_known_ = 0;
    }
    if (ed.empty()) {
      emit(b.raw, b.eol, b.line);
    } else {
      line_.clear();
      ed.render(line_);
      ++r_.changed_blocks;
      emit(line_, b.eol, b.line);
    }
  }

  void finish() {
    out_.write(buffer_);
    buffer_.clear();
  }

 private:
  void correct(const gcode::Block& b, const gcode::Motion& mo, std::size_t pi, gcode::BlockEditor& ed) {
    const contour::PathPoint& p = path_.points[pi];
    const ProgramMap& map = path_.maps[p.map];
    const gcode::AxisMask mask = written_axes(m_, map.form());
    Command out;
    if (!map.command(commands_[pi], p.command, out).ok()) {
      refuse(b, mo.column, "the controller's kinematics failed for the corrected command of this move");
      return;
    }
    for (int a = 0; a < gcode::kAxisCount; ++a)
      if ((mask >> a) & 1u) {
        const double dc = std::abs(out.c[a] - mo.end[a]);
        if (gcode::is_rotary(a)) r_.max_correction_deg = std::max(r_.max_correction_deg, dc);
        else r_.max_correction_mm = std::max(r_.max_correction_mm, dc);
      }
    gcode::Motion m = mo;
    m.tool_vector = p.command.vector;
    const WordWriter::Outcome o = writer_.rewrite(b, m, mask, written_, written_known_, out, ed);
    if (!o.ok) {
      refuse(b, o.column, o.why);
      return;
    }
    r_.words_changed += o.changed;
    r_.words_inserted += o.inserted;
    written_ = out.c;
    written_known_ = static_cast<gcode::AxisMask>(mo.known | mask);
  }

  void refuse(const gcode::Block& b, std::uint32_t column, std::string why) {
    const gcode::Span s{column > 0 ? column - 1 : 0, column > 0 ? column : 1};
    gcode::report_at(gcode::LexContext{file_, &sink_}, b, s, gcode::Severity::error, "PP-E601", std::move(why));
    written_known_ = 0;
  }

  void emit(std::string_view raw, std::string_view eol, std::uint64_t from) {
    if (opt_.line_map != nullptr) opt_.line_map->push_back(from);
    buffer_.append(raw);
    buffer_.append(eol);
    if (buffer_.size() > (1u << 20)) finish();
  }

  std::string_view file_;
  const gcode::Dialect& d_;
  const machine::Machine& m_;
  const CompensateOptions& opt_;
  const contour::Path& path_;
  const std::vector<kin::JointVector>& commands_;
  io::OutputFile& out_;
  gcode::DiagnosticSink& sink_;
  CompensateResult& r_;
  gcode::ModalTrack track_;
  WordWriter writer_{d_, m_, track_};
  std::vector<std::int64_t> point_of_motion_;
  std::uint64_t motion_ = 0;
  gcode::AxisVector written_;
  gcode::AxisMask written_known_ = 0;
  bool header_done_ = false;
  bool arc_noted_ = false;  ///< PP-W611 given (once per program)
  std::string eol_ = "\n";
  std::string line_, buffer_;
};

}  // namespace

CompensateResult compensate_contour(std::string_view text, std::string_view file, const gcode::Dialect& dialect,
                                    const machine::Machine& m, const CompensateOptions& opt,
                                    const contour::PrecompensateOptions& popt, io::OutputFile& out,
                                    gcode::DiagnosticSink& sink, ContourDetails* details) {
  ContourDetails local;
  ContourDetails& d = details != nullptr ? *details : local;
  CompensateResult r;
  r.bytes_in = text.size();
  const std::size_t errors = sink.count(gcode::Severity::error);
  const auto stage = [&](std::string_view what, double done) {
    if (opt.progress) opt.progress(what, done, 0);
  };
  {
    stage("contour: reading the path", 0);
    gcode::LineReader in{text};
    d.path = contour::build_path(in, file, dialect, m, contour::PathOptions{}, sink);
  }
  if (sink.count(gcode::Severity::error) > errors) return r;
  stage("contour: fitting the NURBS reference", 0);
  d.reference.emplace(d.path, *m.actual);
  contour::PrecompensateOptions po = popt;
  if (!po.progress) po.progress = opt.progress;
  d.result = contour::precompensate(d.path, *m.actual, *d.reference, po);
  stage("contour: writing", 0);
  r.contour_before_mm = d.result.before.tip.max;
  r.contour_before_rad = d.result.before.axis.max;
  r.contour_after_mm = d.result.after.tip.max;
  r.contour_after_rad = d.result.after.axis.max;
  r.contour_iterations = d.result.iterations;
  r.contour_converged = d.result.converged;
  r.fit_residual_mm = d.reference->max_fit_residual_mm();
  if (!d.path.points.empty()) r.contour_worst_line = d.path.points[d.result.before.tip.worst].line;
  gcode::DiagnosticSink quiet(0);  // the first pass reported the program's diagnostics already
  ContourWriter w(file, dialect, m, opt, d.path, d.result.commands, out, sink, r);
  gcode::LineReader in{text};
  gcode::run_program(in, dialect, file, quiet, w);
  w.finish();
  return r;
}

}  // namespace postproc::comp
