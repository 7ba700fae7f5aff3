// compensate --mode contour: the program's commanded path, its predicted servo contour errors,
// the precompensated commands, and the program written with the corrected end points.
#include <algorithm>
#include <future>
#include <limits>
#include <memory>
#include <optional>

#include <fmt/format.h>

#include "postproc/compensation/compensate.hpp"
#include "postproc/contour/learning_control.hpp"
#include "postproc/contour/simulate.hpp"
#include "postproc/error.hpp"
#include "postproc/gcode/block_writer.hpp"
#include "postproc/gcode/lexer.hpp"
#include "postproc/gcode/program.hpp"
#include "src/compensation/compensate_support.hpp"
#include "src/gcode/convert_support.hpp"
#include "src/compensation/report_units.hpp"

namespace postproc::comp {
namespace {

/// Second pass: the blocks as read, with the corrected end points written into their words.
class ContourWriter final : public gcode::BlockVisitor {
 public:
  /// `withheld[r]` non-empty: run r of the path is written as read (no contour correction), and
  /// that text is reported (PP-W620 / PP-W621) at the run's first move.
  ContourWriter(std::string_view file, const gcode::Dialect& d, const machine::Machine& m, const CompensateOptions& opt,
                const contour::Path& path, const std::vector<kin::JointVector>& commands,
                const std::vector<std::pair<std::string_view, std::string>>& withheld, io::OutputFile& out,
                gcode::DiagnosticSink& sink, CompensateResult& r)
      : file_(file), d_(d), m_(m), opt_(opt), path_(path), commands_(commands), withheld_(withheld), out_(out),
        sink_(sink), r_(r), track_(d) {
    point_of_motion_.assign(path.motions, -1);
    note_of_motion_.assign(path.motions, -1);
    for (std::size_t run = 0; run < path.runs.size(); ++run) {
      const bool keep = run >= withheld.size() || withheld[run].second.empty();
      bool noted = false;
      for (std::size_t i = path.runs[run].begin; i < path.runs[run].end && i < path.points.size(); ++i) {
        const contour::PathPoint& p = path.points[i];
        if (!p.block_end || p.run_start || p.motion >= point_of_motion_.size()) continue;
        if (keep) {
          point_of_motion_[p.motion] = static_cast<std::int64_t>(i);
        } else if (!noted) {
          noted = true;
          note_of_motion_[p.motion] = static_cast<std::int64_t>(run);
        }
      }
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
    const gcode::Motion* offset = lexed_ok ? cutter_offset_motion(motions) : nullptr;
    if (offset != nullptr && !offset_refused_) {
      offset_refused_ = true;
      const gcode::Span sp{offset->column > 0 ? offset->column - 1 : 0, offset->column > 0 ? offset->column : 1};
      gcode::report_at(gcode::LexContext{file_, &sink_}, b, sp, gcode::Severity::error, "PP-E601",
                       cutter_offset_refusal(*offset));
    }
    if (lexed_ok) {
      for (const gcode::Motion& mo : motions) {
        ++r_.motions;
        const std::uint64_t k = motion_++;
        const std::int64_t pi = k < point_of_motion_.size() ? point_of_motion_[k] : -1;
        if (k < note_of_motion_.size() && note_of_motion_[k] >= 0) {
          const auto& [code, why] = withheld_[static_cast<std::size_t>(note_of_motion_[k])];
          const gcode::Span sp{mo.column > 0 ? mo.column - 1 : 0, mo.column > 0 ? mo.column : 1};
          gcode::report_at(gcode::LexContext{file_, &sink_}, b, sp, gcode::Severity::warning, code, why);
        }
        if (motions.size() == 1 && pi >= 0 && offset == nullptr) {
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
      if (const auto too_long = gcode::line_too_long(d_, line_, b.eol))
        refuse(b, 1, corrected_line_too_long(*too_long));
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
  const std::vector<std::pair<std::string_view, std::string>>& withheld_;
  io::OutputFile& out_;
  gcode::DiagnosticSink& sink_;
  CompensateResult& r_;
  gcode::ModalTrack track_;
  WordWriter writer_{d_, m_, track_};
  std::vector<std::int64_t> point_of_motion_;
  std::vector<std::int64_t> note_of_motion_;  ///< motion → withheld run reported at it (-1: none)
  std::uint64_t motion_ = 0;
  gcode::AxisVector written_;
  gcode::AxisMask written_known_ = 0;
  bool header_done_ = false;
  bool arc_noted_ = false;  ///< PP-W611 given (once per program)
  bool offset_refused_ = false;  ///< a block under LinuxCNC cutter radius compensation was refused
  std::string eol_ = "\n";
  std::string line_, buffer_;
};

}  // namespace

std::optional<contour::Simulation> simulate_written(const std::string& written, std::string_view file,
                                                    const gcode::Dialect& dialect, const machine::Machine& m,
                                                    const ContourDetails& d, std::string& why,
                                                    const contour::SimulateOptions& so) {
  gcode::DiagnosticSink quiet(0);
  gcode::LineReader in{std::string_view(written)};
  const contour::Path p = contour::build_path(in, file, dialect, m, contour::PathOptions{}, quiet);
  if (quiet.has_errors()) {
    why = "the written program reads back with errors";
    return std::nullopt;
  }
  if (p.runs.size() != d.path.runs.size()) {
    why = fmt::format("the written program has {} runs, its input {}", p.runs.size(), d.path.runs.size());
    return std::nullopt;
  }
  if (so.visit && p.points.size() != d.path.points.size()) {
    why = fmt::format("the written program has {} path points, its input {}", p.points.size(), d.path.points.size());
    return std::nullopt;
  }
  try {
    return contour::simulate(p, d.check_reference ? *d.check_reference : *d.reference, *m.actual, so);
  } catch (const Error& e) {
    why = e.what();
    return std::nullopt;
  }
}

namespace {

/// Tool-axis angles closer than this are equal (numerical noise of the forward kinematics on
/// machines that cannot tilt the tool, 2e-4 arcsec; the coarsest written rotary step, 0.0001°, is
/// 1.7e-6 rad), rad.
constexpr double kAxisNoiseRad = 1e-9;

/// Tool-tip figures closer than this are equal (mm): simulation noise, far below a written digit.
constexpr double kTipNoiseMm = 1e-7;

/// The simulated figures of one run: largest errors and RMS, tool tip (mm) and tool axis (rad).
struct RunFigures {
  double tip = 0, axis = 0, tip_rms = 0, axis_rms = 0;
};
RunFigures figures_of(const contour::Simulation& s, std::size_t r) {
  return {s.run_tip_max[r], s.run_axis_max[r], s.run_tip_rms[r], s.run_axis_rms[r]};
}

/// c is not worse than o in any of the four figures (the gate's first rule): neither largest
/// error (tool tip, tool axis) nor either RMS grows. A candidate that lowers a peak but cuts the
/// rest of the run worse (the RMS grows) does not qualify.
bool not_worse(const RunFigures& c, const RunFigures& o) {
  return c.tip <= o.tip && c.axis <= o.axis + kAxisNoiseRad && c.tip_rms <= o.tip_rms + kTipNoiseMm &&
         c.axis_rms <= o.axis_rms + kAxisNoiseRad;
}
bool not_worse(const contour::Simulation& c, const contour::Simulation& o, std::size_t r) {
  return not_worse(figures_of(c, r), figures_of(o, r));
}

/// c is better than o: not worse in any figure, and one of the maxima or the tool-tip RMS smaller
/// by more than the noise.
bool better(const RunFigures& c, const RunFigures& o) {
  return not_worse(c, o) &&
         (c.tip < o.tip - kTipNoiseMm || c.axis < o.axis - kAxisNoiseRad || c.tip_rms < o.tip_rms - kTipNoiseMm);
}
bool better(const contour::Simulation& c, const contour::Simulation& o, std::size_t r) {
  return better(figures_of(c, r), figures_of(o, r));
}

/// Nothing changed in run r (same maxima): no reason to withhold or report it.
bool same(const contour::Simulation& w, const contour::Simulation& o, std::size_t r) {
  return w.run_tip_max[r] == o.run_tip_max[r] && w.run_axis_max[r] == o.run_axis_max[r];
}

/// Two candidates' largest errors closer than this (relative, and at least 1 nm) tie: the RMS decides.
constexpr double kMaxTie = 0.02;

/// Of two candidates better than the input in run r, the first is preferred: the smaller largest
/// error (tip + L × axis), and on a tie the smaller RMS.
bool prefer(const contour::Simulation& a, const contour::Simulation& b, std::size_t r, double length) {
  const double ka = a.run_tip_max[r] + length * a.run_axis_max[r], kb = b.run_tip_max[r] + length * b.run_axis_max[r];
  if (std::abs(ka - kb) > std::max(1e-6, kMaxTie * std::min(ka, kb))) return ka < kb;
  return a.run_tip_rms[r] + length * a.run_axis_rms[r] <= b.run_tip_rms[r] + length * b.run_axis_rms[r];
}

enum class Choice : std::uint8_t { uncorrected, lag, iterated, refined };

/// The refinement of one run on the simulation.
struct Refined {
  int steps = 0;         ///< accepted steps
  int trials = 0;        ///< simulations of trial steps
  RunFigures figures{};  ///< simulated figures of the refined commands (when steps > 0)
};

/// Refinement on the simulation (contour/learning_control.hpp), all runs at once: every round
/// writes the trial commands (`write(commands)` → the text), reads them back and simulates the
/// runs still refining (`simulate(text, equations, why, runs)` gathers their samples' normal
/// equations); per run the step is taken where the run stays within `box` (none of its four
/// figures above the program as received) and its merit (the four figures, each relative to the
/// box's, summed) falls, else halved; a run stops
/// after LearningOptions::max_iterations steps, when a step gains less than the relative
/// tolerance of the merit, or after max_halvings halvings in a row; a halved step keeps its length
/// for the run's later steps. `cur` (per path point) holds the start and receives the result. At
/// most 2 × max_iterations + max_halvings rounds (a cap on the whole refinement).
template <class Write, class Simulate>
std::vector<Refined> refine(const contour::Path& path, std::vector<kin::JointVector>& cur,
                            const std::vector<RunFigures>& start_figures, const std::vector<RunFigures>& box,
                            const contour::LearningOptions& lo,
                            Write&& write, Simulate&& simulate) {
  // `simulate(text, equations, why, runs)`: runs == nullptr simulates every run, else the runs
  // marked (the trials of the runs still refining).
  const std::size_t runs = path.runs.size();
  std::vector<Refined> out(runs);
  contour::SampleEquations eq_cur(path, lo.orientation_length_mm, lo.dynamic), eq_trial(path, lo.orientation_length_mm, lo.dynamic);
  std::string why;
  // Each run's tool-tip and tool-axis rows weighted by the inverse of the start's RMS of each (L ×
  // axis in mm; `start_figures`: the gate's simulation of the candidate each run starts from): the
  // step lowers both in proportion instead of trading one for the other (the acceptance wants
  // neither worse).
  for (std::size_t r = 0; r < runs && r < start_figures.size(); ++r) {
    const RunFigures& f = start_figures[r];
    const double wt = 1 / std::max(f.tip_rms, 1e-6), wa = 1 / std::max(lo.orientation_length_mm * f.axis_rms, 1e-6);
    eq_cur.weigh(r, wt, wa);
    eq_trial.weigh(r, wt, wa);
  }
  const std::optional<contour::Simulation> sim = simulate(write(cur), eq_cur, why, nullptr);
  if (!sim) return out;
  std::vector<RunFigures> fig(runs);
  std::vector<double> alpha(runs, 1.0);
  std::vector<int> halvings(runs, 0);
  std::vector<char> active(runs, 0), fresh(runs, 1);
  for (std::size_t r = 0; r < runs; ++r) {
    fig[r] = figures_of(*sim, r);
    const contour::Run& run = path.runs[r];
    bool any = false;
    for (std::size_t i = run.begin; i < run.end && !any; ++i) any = contour::correctable(path, run, i);
    active[r] = any && (fig[r].tip > 0 || fig[r].axis > 0) ? 1 : 0;
  }
  std::vector<kin::JointVector> step(path.points.size(), kin::JointVector::Zero(path.joints)), trial = cur;
  const int rounds = 2 * lo.max_iterations + lo.max_halvings;
  for (int round = 0; round < rounds && std::find(active.begin(), active.end(), 1) != active.end(); ++round) {
    for (std::size_t r = 0; r < runs; ++r) {
      if (active[r] == 0) continue;
      const contour::Run& run = path.runs[r];
      if (fresh[r] != 0) {
        for (std::size_t i = run.begin; i < run.end; ++i) step[i].setZero();
        eq_cur.solve(run, lo, step);
        fresh[r] = 0;
      }
      for (std::size_t i = run.begin; i < run.end; ++i) trial[i] = cur[i] + alpha[r] * step[i];
    }
    eq_trial.clear();
    const std::optional<contour::Simulation> ts = simulate(write(trial), eq_trial, why, &active);
    if (!ts) break;
    for (std::size_t r = 0; r < runs; ++r) {
      if (active[r] == 0) continue;
      const contour::Run& run = path.runs[r];
      ++out[r].trials;
      const RunFigures got = figures_of(*ts, r), was = fig[r];
      // Taken when it stays within the box (no figure worse than the program as received, which
      // the final choice requires) and lowers the merit: the four figures (largest tool-tip and
      // tool-axis errors, their RMS), each relative to the box's, summed. One figure may rise on
      // the way where the others fall more.
      const RunFigures& b = box[r];
      const auto merit_of = [&](const RunFigures& f) {
        return f.tip / std::max(b.tip, kTipNoiseMm) + f.tip_rms / std::max(b.tip_rms, kTipNoiseMm) +
               f.axis / std::max(b.axis, kAxisNoiseRad) + f.axis_rms / std::max(b.axis_rms, kAxisNoiseRad);
      };
      const double merit = merit_of(got), merit_was = merit_of(was);
      if (not_worse(got, b) && merit < merit_was - 1e-6) {
        for (std::size_t i = run.begin; i < run.end; ++i) cur[i] = trial[i];
        fig[r] = out[r].figures = got;
        ++out[r].steps;
        eq_cur.take_run(eq_trial, run);
        fresh[r] = 1;
        // The step length stays where it was taken: a step that needed halving is most likely
        // refused again at twice its length (a round lost per step).
        halvings[r] = 0;
        if (out[r].steps >= lo.max_iterations || merit_was - merit < lo.relative_tolerance * merit)
          active[r] = 0;
      } else {
        for (std::size_t i = run.begin; i < run.end; ++i) trial[i] = cur[i];
        alpha[r] *= 0.5;
        if (++halvings[r] > lo.max_halvings) active[r] = 0;
      }
    }
  }
  return out;
}

}  // namespace

CompensateResult compensate_contour(const ProgramInput& program, const CompensateOptions& opt, io::OutputFile& out,
                                    gcode::DiagnosticSink& sink, ContourDetails* details) {
  const std::string_view text = program.text, file = program.file;
  const gcode::Dialect& dialect = program.dialect;
  const machine::Machine& m = program.machine;
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
  {
    contour::PathOptions dense;
    dense.densify_mm = contour::kReferenceDensifyMm;
    gcode::DiagnosticSink quiet(0);
    gcode::LineReader in{text};
    const contour::Path p = contour::build_path(in, file, dialect, m, dense, quiet);
    if (!quiet.has_errors() && p.runs.size() == d.path.runs.size()) d.check_reference.emplace(p, *m.actual);
  }
  contour::PrecompensateOptions po = opt.contour;
  if (!po.progress) po.progress = opt.progress;
  d.result = contour::precompensate(d.path, *m.actual, *d.reference, po);
  r.contour_predicted_after_mm = d.result.after.tip.max;
  r.contour_predicted_after_rad = d.result.after.axis.max;
  r.contour_iterations = d.result.iterations;
  r.contour_converged = d.result.converged;
  r.contour_runs = d.path.runs.size();
  r.fit_residual_mm = d.reference->max_fit_residual_mm();
  if (!d.path.points.empty()) r.contour_worst_line = d.path.points[d.result.before.tip.worst].line;

  // One writing pass of `commands` with the runs in `withheld` left as read, into memory; its
  // figures, diagnostics and line map are kept only for the pass that is written.
  using Withheld = std::vector<std::pair<std::string_view, std::string>>;
  struct Pass {
    std::string text;
    CompensateResult r;
    gcode::DiagnosticSink sink{std::numeric_limits<std::size_t>::max()};
    std::vector<std::uint64_t> lines;
  };
  const auto write_pass = [&](const std::vector<kin::JointVector>& commands, const Withheld& withheld) {
    auto p = std::make_unique<Pass>();
    p->r = r;
    CompensateOptions o = opt;
    o.line_map = opt.line_map != nullptr ? &p->lines : nullptr;
    auto mem = io::OutputFile::memory();
    ContourWriter w(file, dialect, m, o, d.path, commands, withheld, mem, p->sink, p->r);
    gcode::DiagnosticSink quiet(0);  // the first pass reported the program's diagnostics already
    gcode::LineReader in{text};
    gcode::run_program(in, dialect, file, quiet, w);
    w.finish();
    p->text = mem.take();
    return p;
  };

  // The verification gate (docs/compensation-verification.md): the input and two candidates, the
  // iterated correction and the first-order lag precompensation, are written, read back and
  // simulated in the time domain (contour/simulate.hpp) against the same intended contour; each
  // run is written with the best of {uncorrected, lag, iterated}: never worse than the input at
  // its maxima, then the smaller largest error, then the smaller RMS.
  stage("contour: writing and verifying by simulation", 0);
  const std::size_t runs = d.path.runs.size();
  const Withheld none(runs);
  // The simulations run on other threads while the candidates are written on this one (the
  // written texts are read back into paths of their own; models and reference are immutable).
  std::future<contour::Simulation> input_sim =
      std::async(std::launch::async, [&d, &m] {
        return contour::simulate(d.path, d.check_reference ? *d.check_reference : *d.reference, *m.actual);
      });
  std::unique_ptr<Pass> iterated = write_pass(d.result.commands, none);
  std::string why_iterated, why_lag;
  std::future<std::optional<contour::Simulation>> iterated_sim = std::async(std::launch::async, [&] {
    return simulate_written(iterated->text, file, dialect, m, d, why_iterated);
  });
  std::unique_ptr<Pass> lag = write_pass(d.result.lag_commands, none);
  std::optional<contour::Simulation> sim_lag = simulate_written(lag->text, file, dialect, m, d, why_lag);
  std::optional<contour::Simulation> sim_iterated = iterated_sim.get();
  std::string why;
  std::optional<contour::Simulation> before, after;
  try {
    before = input_sim.get();
  } catch (const Error& e) {
    why = fmt::format("the contour stage's input cannot be simulated ({})", e.what());
  }
  const double L = po.orientation_length_mm;
  std::vector<Choice> choice(runs, Choice::uncorrected);
  Withheld withheld(runs);
  const auto withhold_all = [&](std::string_view because) {
    for (auto& w : withheld)
      w = {kContourUnverified,
           fmt::format("contour correction not written: {}; the program is written as the contour stage received it "
                       "(without the servo correction)",
                       because)};
    std::fill(choice.begin(), choice.end(), Choice::uncorrected);
  };
  const auto fig = [](const std::optional<contour::Simulation>& s, std::size_t run) {
    return s ? fmt::format("{:.3f} µm / {:.2f} arcsec", s->run_tip_max[run] * 1000, s->run_axis_max[run] * kArcsecPerRad)
             : std::string("not simulated");
  };
  std::unique_ptr<Pass> pass;
  std::vector<kin::JointVector> refined_commands;
  std::vector<Refined> refined_steps(runs);
  if (before && (sim_iterated || sim_lag)) {
    for (std::size_t run = 0; run < runs; ++run) {
      const bool it_ok = sim_iterated && better(*sim_iterated, *before, run);
      const bool lag_ok = sim_lag && better(*sim_lag, *before, run);
      if (it_ok && (!lag_ok || prefer(*sim_iterated, *sim_lag, run, L))) choice[run] = Choice::iterated;
      else if (lag_ok) choice[run] = Choice::lag;
      else if (d.result.runs[run].stop == contour::RunStop::nothing ||
               ((!sim_iterated || same(*sim_iterated, *before, run)) && (!sim_lag || same(*sim_lag, *before, run))))
        // Nothing changed (a run without a point to correct; its simulation may still differ by
        // clock noise): nothing to report; written with the candidate that keeps the passes whole.
        choice[run] = sim_iterated ? Choice::iterated : Choice::lag;
      else {
        const contour::Run& rr = d.path.runs[run];
        const contour::RunIteration& ri = d.result.runs[run];
        withheld[run] = {
            kContourWithheld,
            fmt::format("contour correction of the run starting here ({} moves) not written: the time-domain simulation "
                        "gives a largest contour error of {} with the iterated correction ({} iterations, {}; predicted "
                        "{:.3f} µm) and {} with the first-order lag precompensation, against {} without; the run is "
                        "written as the contour stage received it",
                        rr.size() - 1, fig(sim_iterated, run), ri.iterations, contour::to_string(ri.stop),
                        ri.after_tip_mm * 1000, fig(sim_lag, run), fig(before, run))};
      }
    }
    // Refinement on the simulation (contour/learning_control.hpp), from each run's choice: a run's
    // step is taken only where the simulation of the written trial keeps the run within the
    // received program's figures and lowers its merit, else halved.
    if (po.learning_iterations > 0) {
      for (const contour::PathPoint& p : d.path.points) refined_commands.push_back(p.q);
      for (std::size_t run = 0; run < runs; ++run)
        for (std::size_t i = d.path.runs[run].begin; i < d.path.runs[run].end; ++i)
          if (choice[run] != Choice::uncorrected)
            refined_commands[i] = choice[run] == Choice::lag ? d.result.lag_commands[i] : d.result.commands[i];
      contour::LearningOptions lo;
      lo.max_iterations = po.learning_iterations;
      lo.orientation_length_mm = L;
      lo.smoothing = po.smoothing;
      const auto write = [&](const std::vector<kin::JointVector>& c) { return write_pass(c, none)->text; };
      std::vector<RunFigures> start_figures(runs);
      for (std::size_t run = 0; run < runs; ++run)
        start_figures[run] = figures_of(choice[run] == Choice::lag        ? *sim_lag
                                        : choice[run] == Choice::iterated ? *sim_iterated
                                                                          : *before,
                                        run);
      // The box: no figure above the program as received nor above the candidate the run starts from.
      std::vector<RunFigures> box(runs);
      for (std::size_t run = 0; run < runs; ++run) {
        const RunFigures b = figures_of(*before, run), s = start_figures[run];
        box[run] = RunFigures{std::min(b.tip, s.tip), std::min(b.axis, s.axis), std::min(b.tip_rms, s.tip_rms),
                              std::min(b.axis_rms, s.axis_rms)};
      }
      refined_steps = refine(d.path, refined_commands, start_figures, box, lo, write, [&](const std::string& written, contour::SampleEquations& eq,
                                                                     std::string& because, const std::vector<char>* runs_to) {
        contour::SimulateOptions so;
        so.visit = [&eq](const contour::SampleVisit& v) { eq.add(v); };
        so.only_runs = runs_to;
        return simulate_written(written, file, dialect, m, d, because, so);
      });
      for (std::size_t run = 0; run < runs; ++run) {
        if (refined_steps[run].steps == 0 || !better(refined_steps[run].figures, figures_of(*before, run))) continue;
        choice[run] = Choice::refined;
        withheld[run] = {};
      }
    }
    // The written program: one of the candidates as it is, or the runs' choices merged and
    // verified once more (runs are independent, so this confirms the candidates' figures).
    const bool all_iterated = std::all_of(choice.begin(), choice.end(), [](Choice c) { return c == Choice::iterated; });
    const bool all_lag = std::all_of(choice.begin(), choice.end(), [](Choice c) { return c == Choice::lag; });
    if (all_iterated) {
      pass = std::move(iterated);
      after = sim_iterated;
    } else if (all_lag) {
      pass = std::move(lag);
      after = sim_lag;
    } else {
      std::vector<kin::JointVector> merged = d.result.commands;
      for (std::size_t run = 0; run < runs; ++run)
        for (std::size_t i = d.path.runs[run].begin; i < d.path.runs[run].end; ++i)
          if (choice[run] == Choice::lag) merged[i] = d.result.lag_commands[i];
          else if (choice[run] == Choice::refined) merged[i] = refined_commands[i];
      for (int round = 0; round < 4; ++round) {
        pass = write_pass(merged, withheld);
        after = simulate_written(pass->text, file, dialect, m, d, why);
        if (!after) break;
        bool changed = false;
        for (std::size_t run = 0; run < runs; ++run) {
          // Runs without a point to correct are written as received whatever their candidate.
          if (choice[run] == Choice::uncorrected || d.result.runs[run].stop == contour::RunStop::nothing ||
              not_worse(*after, *before, run))
            continue;
          choice[run] = Choice::uncorrected;
          withheld[run] = {kContourWithheld,
                           fmt::format("contour correction of the run starting here ({} moves) not written: the "
                                       "simulation of the program as written gives {} against {} without it; the run "
                                       "is written as the contour stage received it",
                                       d.path.runs[run].size() - 1, fig(after, run), fig(before, run))};
          changed = true;
        }
        if (!changed) break;
        after.reset();
      }
    }
    if (!after) {
      if (why.empty()) why = "the runs kept changing from one verification to the next";
      withhold_all(fmt::format("the written program could not be verified by simulation ({})", why));
      pass = write_pass(d.result.commands, withheld);
      after = simulate_written(pass->text, file, dialect, m, d, why);
    }
  } else {
    if (before) why = why_iterated.empty() ? why_lag : why_iterated;
    withhold_all(before ? fmt::format("the written program could not be verified by simulation ({})", why) : why);
    pass = write_pass(d.result.commands, withheld);
    if (before) after = simulate_written(pass->text, file, dialect, m, d, why);
  }
  CompensateResult& out_r = pass->r;
  for (const auto& w : withheld)
    if (!w.second.empty()) ++out_r.contour_runs_withheld;
  d.run_withheld.assign(runs, 0);
  for (std::size_t i = 0; i < runs; ++i) d.run_withheld[i] = withheld[i].second.empty() ? 0 : 1;
  // Per run: the iteration, the candidates simulated, and what was written.
  out_r.contour_run_reports.resize(runs);
  for (std::size_t run = 0; run < runs; ++run) {
    ContourRunReport& rep = out_r.contour_run_reports[run];
    const contour::Run& rr = d.path.runs[run];
    const contour::RunIteration& ri = d.result.runs[run];
    rep.line = rr.begin < d.path.points.size() ? d.path.points[rr.begin].line : 0;
    rep.moves = rr.size() > 0 ? rr.size() - 1 : 0;
    rep.iterations = ri.iterations;
    rep.stop = std::string(contour::to_string(ri.stop));
    rep.written = choice[run] == Choice::refined                                             ? "refined"
                  : choice[run] == Choice::uncorrected || ri.stop == contour::RunStop::nothing ? "uncorrected"
                  : choice[run] == Choice::lag                                               ? "lag"
                                                                                             : "iterated";
    rep.refined_steps = refined_steps[run].steps;
    if (refined_steps[run].steps > 0) {
      rep.refined_mm = refined_steps[run].figures.tip;
      rep.refined_rad = refined_steps[run].figures.axis;
      rep.refined_rms_mm = refined_steps[run].figures.tip_rms;
    }
    rep.predicted_before_mm = ri.before_tip_mm;
    rep.predicted_after_mm = ri.after_tip_mm;
    if (before) {
      rep.before_mm = before->run_tip_max[run];
      rep.before_rad = before->run_axis_max[run];
      rep.before_rms_mm = before->run_tip_rms[run];
    }
    if (sim_iterated || (choice[run] == Choice::iterated && after)) {
      const contour::Simulation& s = sim_iterated ? *sim_iterated : *after;
      rep.iterated_mm = s.run_tip_max[run];
      rep.iterated_rad = s.run_axis_max[run];
      rep.iterated_rms_mm = s.run_tip_rms[run];
    }
    if (sim_lag || (choice[run] == Choice::lag && after)) {
      const contour::Simulation& s = sim_lag ? *sim_lag : *after;
      rep.lag_mm = s.run_tip_max[run];
      rep.lag_rad = s.run_axis_max[run];
      rep.lag_rms_mm = s.run_tip_rms[run];
    }
    if (rep.written == "iterated") ++out_r.contour_runs_iterated;
    if (rep.written == "lag") ++out_r.contour_runs_lag;
    if (rep.written == "refined") ++out_r.contour_runs_refined;
    ++out_r.contour_runs_stopped[static_cast<std::size_t>(ri.stop)];
  }
  if (std::any_of(choice.begin(), choice.end(), [](Choice c) { return c != Choice::iterated; })) {
    // The prediction shown next to the simulation (--html) is that of the commands as written.
    std::vector<kin::JointVector> written = d.result.commands;
    for (std::size_t run = 0; run < runs; ++run)
      if (choice[run] != Choice::iterated)
        for (std::size_t i = d.path.runs[run].begin; i < d.path.runs[run].end && i < written.size(); ++i)
          written[i] = choice[run] == Choice::lag       ? d.result.lag_commands[i]
                       : choice[run] == Choice::refined ? refined_commands[i]
                                                        : d.path.points[i].q;
    d.result.after = contour::predict(d.path, *m.actual, *d.reference, &written);
  }
  d.simulated_before = before;
  d.simulated_after = after;
  if (before && after) {
    out_r.contour_verified = true;
    out_r.contour_before_mm = before->tip.max;
    out_r.contour_before_rad = before->axis.max;
    out_r.contour_after_mm = after->tip.max;
    out_r.contour_after_rad = after->axis.max;
    out_r.contour_worst_line = before->worst_tip_line;
  } else {
    // Not simulated: everything is written as received; the figures are the prediction of that.
    out_r.contour_before_mm = out_r.contour_after_mm = d.result.before.tip.max;
    out_r.contour_before_rad = out_r.contour_after_rad = d.result.before.axis.max;
  }
  for (const gcode::Diagnostic& diag : pass->sink.stored()) sink.report(diag);
  if (opt.line_map != nullptr) opt.line_map->insert(opt.line_map->end(), pass->lines.begin(), pass->lines.end());
  out.write(pass->text);
  return std::move(pass->r);
}

}  // namespace postproc::comp
