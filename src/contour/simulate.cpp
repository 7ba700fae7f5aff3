// Time-domain simulation of the servo drives along the commanded path (see simulate.hpp).
#include "postproc/contour/simulate.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include "postproc/error.hpp"

namespace postproc::contour {
namespace {
/// Added to the search window along the reference (mm): covers the rounding of the arc measure
/// and the chords' departure from the fitted curve.
constexpr double kWindowMarginMm = 0.005;
}  // namespace

Simulation simulate(const Path& commanded, const Reference& ref, const kin::Model& actual, const SimulateOptions& opt) {
  if (commanded.runs.size() != ref.runs())
    throw Error(ExitCode::usage, "simulate: the commanded path has " + std::to_string(commanded.runs.size()) +
                                     " runs, the reference " + std::to_string(ref.runs()));
  const int nj = commanded.joints;
  if (nj <= 0 || nj > kin::kMaxJoints || nj != actual.joint_count())
    throw Error(ExitCode::usage, "simulate: the path has " + std::to_string(nj) + " joints, the model " +
                                     std::to_string(actual.joint_count()));
  if (commanded.drives.size() != static_cast<std::size_t>(nj))
    throw Error(ExitCode::usage, "simulate: " + std::to_string(commanded.drives.size()) + " drives for " +
                                     std::to_string(nj) + " joints");
  if (!(commanded.period > 0)) throw Error(ExitCode::usage, "simulate: the interpolation period must be > 0");
  if (!(opt.settle_s >= 0)) throw Error(ExitCode::usage, "simulate: settle_s must be ≥ 0");

  const auto uj = static_cast<std::size_t>(nj);
  const double dt = commanded.period;
  Simulation sim;
  sim.max_following.assign(uj, 0.0);
  sim.run_tip_max.assign(commanded.runs.size(), 0.0);
  sim.run_axis_max.assign(commanded.runs.size(), 0.0);
  sim.run_tip_rms.assign(commanded.runs.size(), 0.0);  // sums of squares until the run ends
  sim.run_axis_rms.assign(commanded.runs.size(), 0.0);
  std::vector<double> tip_mm, axis_rad;  // per sample, for the summaries
  double worst_tip = -1, worst_axis = -1;
  // s: start of the current run in simulation time. Runs follow each other on the interpolation
  // grid: a run's first sample comes one period after the previous run's last (settling) sample.
  double offset = 0;
  std::array<DriveState, kin::kMaxJoints> state{};
  kin::JointVector prev(nj), prev2(nj), y(nj);
  kin::Pose pose;

  for (std::size_t r = 0; r < commanded.runs.size(); ++r) {
    const Run& run = commanded.runs[r];
    if (opt.only_runs != nullptr && (r >= opt.only_runs->size() || (*opt.only_runs)[r] == 0)) continue;
    if (run.begin >= run.end || run.end > commanded.points.size())
      throw Error(ExitCode::internal, "simulate: run " + std::to_string(r) + " outside the path's points");
    const kin::JointVector& q0 = commanded.points[run.begin].q;
    for (std::size_t j = 0; j < uj; ++j) state[j] = DriveState{q0[static_cast<Eigen::Index>(j)], 0.0};
    prev = q0;
    prev2 = q0;
    int history = 0;       // command samples behind prev that are known (for the acceleration)
    double t_prev = 0;     // s, run time of the last sample
    const double t0 = commanded.points[run.begin].t;  // s, the path's time at the run start
    // Tracking along the reference (issue 17 item 5). The commanded point progresses along its
    // program, so its place on the reference is found monotonically: when the reference run has
    // the same points (the same program, or a corrected one: same block structure), starting from
    // the chord of the segment the interpolator is on, and tracked forward from there. The
    // actual point lags its command by about |actual − command| along the path, so its foot is
    // searched only within twice that arc length (plus the command's own distance to the
    // reference) around the command's place: a neighbouring pass nearer in space lies outside.
    const Run ref_run = ref.run(r);
    const bool same_points = ref_run.size() == run.size();
    Place place;
    place.point = ref_run.begin;
    kin::Pose commanded_pose, previous_command;
    bool first = true;
    bool sampled = false;  // a run without a move has no samples and takes no time
    std::uint64_t run_samples = 0;
    double t_last = 0;     // s, run time of the run's last sample

    interpolate(commanded, run, opt.settle_s, [&](const Sample& s) {
      const double t = s.t - t0;  // run time
      sampled = true;
      t_last = t;
      const double h = t - t_prev;
      if (h > 0) {  // a sample at the run's start (t = 0) is where the drives already are
        for (std::size_t j = 0; j < uj; ++j) {
          const auto ej = static_cast<Eigen::Index>(j);
          // Acceleration of the command for the feed-forward term: second difference of the last
          // three samples (0 until there are three).
          const double a = history >= 1 ? (s.q[ej] - 2 * prev[ej] + prev2[ej]) / (dt * dt) : 0.0;
          step(commanded.drives[j], state[j], prev[ej], s.q[ej], a, h);
        }
        prev2 = prev;
        prev = s.q;
        history = std::min(history + 1, 2);
        t_prev = t;
      }
      for (std::size_t j = 0; j < uj; ++j) {
        const auto ej = static_cast<Eigen::Index>(j);
        y[ej] = state[j].y;
        sim.max_following[j] = std::max(sim.max_following[j], std::abs(s.q[ej] - y[ej]));
      }
      const kin::Model& model = model_at(commanded, s.segment, actual);
      const auto forward = [&](const kin::JointVector& q, kin::Pose& out, const char* what) {
        const kin::Solve fk = model.forward(q, out);
        if (!fk.ok())
          throw Error(ExitCode::refused, "simulate: the forward kinematics of the " + model.kind() + " model failed at t = " +
                                             std::to_string(offset + t) + " s (line " +
                                             std::to_string(commanded.points[s.segment].line) + what + "): " +
                                             std::string(kin::to_string(fk.status)));
      };
      forward(y, pose, "");
      forward(s.q, commanded_pose, ", the command");
      if (first) previous_command = commanded_pose;
      first = false;
      if (same_points) {  // start from the interpolator's segment (never backward)
        const Place p = ref.place_on(commanded_pose, ref_run.begin + (s.segment - 1 - run.begin));
        if (p.arc >= place.arc) place = p;
      }
      // Forward from there over the chords the command can have reached: a corrected program's
      // command may lie ahead of its own segment (the lag precompensation leads by v/Kv).
      place = ref.follow(commanded_pose, place,
                         ref.pose_distance(commanded_pose, previous_command) + 2 * place.distance + kWindowMarginMm);
      previous_command = commanded_pose;
      const double w = 2 * (ref.pose_distance(pose, commanded_pose) + place.distance) + kWindowMarginMm;
      const ContourError ce = ref.error_within(pose, place, place.arc - w, place.arc + w);
      if (opt.visit) opt.visit(SampleVisit{r, s.segment, s.fraction, y, model, ce, s.t, &commanded});
      const std::uint64_t line = commanded.points[s.segment].line;
      if (ce.distance > worst_tip) {
        worst_tip = ce.distance;
        sim.worst_tip_line = line;
      }
      if (ce.angle > worst_axis) {
        worst_axis = ce.angle;
        sim.worst_axis_line = line;
      }
      sim.run_tip_max[r] = std::max(sim.run_tip_max[r], ce.distance);
      sim.run_axis_max[r] = std::max(sim.run_axis_max[r], ce.angle);
      sim.run_tip_rms[r] += ce.distance * ce.distance;
      sim.run_axis_rms[r] += ce.angle * ce.angle;
      ++run_samples;
      tip_mm.push_back(ce.distance);
      axis_rad.push_back(ce.angle);
      if (opt.keep_every > 0 && sim.samples % opt.keep_every == 0) {
        SimSample k;
        k.t = offset + t;
        k.run = r;
        k.line = line;
        k.command = s.q;
        k.actual = y;
        k.tip = pose.p;
        k.tip_mm = ce.distance;
        k.axis_rad = ce.angle;
        sim.kept.push_back(std::move(k));
      }
      ++sim.samples;
    });
    if (sampled) offset += t_last + dt;
    if (run_samples > 0) {
      sim.run_tip_rms[r] = std::sqrt(sim.run_tip_rms[r] / static_cast<double>(run_samples));
      sim.run_axis_rms[r] = std::sqrt(sim.run_axis_rms[r] / static_cast<double>(run_samples));
    }
  }
  sim.tip = summarise(tip_mm);
  sim.axis = summarise(axis_rad);
  return sim;
}

}  // namespace postproc::contour
