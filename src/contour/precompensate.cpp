// Contour precompensation run by run (precompensate.hpp): the per-point shift onto the intended
// pose, smoothed along the run, its lag added, step control per run; and the first-order lag
// precompensation that serves as baseline and candidate.
#include "postproc/contour/precompensate.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <optional>

#include <Eigen/Cholesky>

#include "postproc/error.hpp"
#include "src/contour/correction_smoothing.hpp"

namespace postproc::contour {

std::string_view to_string(RunStop s) {
  switch (s) {
    case RunStop::nothing: return "nothing to correct";
    case RunStop::converged: return "converged";
    case RunStop::no_improvement: return "no improvement";
    case RunStop::cap: return "iteration limit";
  }
  return "?";
}

bool correctable(const Path& path, const Run& run, std::size_t i) {
  const PathPoint& p = path.points[i];
  // Not the run's last point: the machine comes to rest there and settles on its command, so a
  // correction made for the lag in motion would stay as an error.
  // Not the start of an arc either: the arc is written as it is, and a moved start point would
  // change its shape (R) or make its centre inconsistent (I J K, refused by the controller).
  return p.block_end && !p.run_start && i > run.begin && i + 1 < run.end && path.points[i + 1].block_end;
}

namespace {

/// How the intended pose moves along the path at point i, per mm of tool-tip travel: the unit
/// tangent of the tip (central chord) and the rotation rate of the tool axis (rad/mm); zero where
/// the tip stands still.
struct Slide {
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();
  Eigen::Vector3d turn = Eigen::Vector3d::Zero();
};
Slide slide_at(const Reference& ref, const Run& run, std::size_t i) {
  const std::size_t a = i > run.begin ? i - 1 : i;
  const std::size_t b = i + 1 < run.end ? i + 1 : i;
  const kin::Pose& pa = ref.intended(a);
  const kin::Pose& pb = ref.intended(b);
  const double ds = (pb.p - pa.p).norm();
  Slide s;
  if (ds <= 1e-9) return s;
  s.tip = (pb.p - pa.p) / ds;
  s.turn = pa.axis().cross(pb.axis()) / ds;
  return s;
}

/// The figures of one run's prediction that the step control compares.
struct RunFigures {
  double tip = 0, axis = 0, tip_rms = 0, axis_rms = 0;
  double score = 0;  ///< largest tip error + L × largest axis error, mm
  double rms = 0;    ///< tip RMS + L × axis RMS, mm
};

RunFigures figures(const std::vector<PointPrediction>& pts, const Run& run, double length) {
  RunFigures f;
  double st = 0, sa = 0;
  for (std::size_t i = run.begin; i < run.end; ++i) {
    f.tip = std::max(f.tip, pts[i].tip_mm);
    f.axis = std::max(f.axis, pts[i].axis_rad);
    st += pts[i].tip_mm * pts[i].tip_mm;
    sa += pts[i].axis_rad * pts[i].axis_rad;
  }
  const double n = run.size() > 0 ? static_cast<double>(run.size()) : 1.0;
  f.tip_rms = std::sqrt(st / n);
  f.axis_rms = std::sqrt(sa / n);
  f.score = f.tip + length * f.axis;
  f.rms = f.tip_rms + length * f.axis_rms;
  return f;
}

/// Below this the run's figures are equal (mm): the prediction's noise on a step that changes
/// nothing at the worst point (a run's end, where no correction acts).
constexpr double kSameMm = 1e-9;

/// The trial is not worse than the current iterate in either figure, and better in one.
bool improves(const RunFigures& trial, const RunFigures& cur) {
  return trial.score <= cur.score + kSameMm && trial.rms <= cur.rms + kSameMm &&
         (trial.score < cur.score - kSameMm || trial.rms < cur.rms - kSameMm);
}

using Matrix6n = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, kin::kMaxJoints + 1>;
using Square =
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kin::kMaxJoints + 1, kin::kMaxJoints + 1>;

/// The joint shift at point i that moves the predicted actual pose onto the intended pose at its
/// foot (docs/contour.md): J·d = [ε_tip; L·ε_axis] in damped least squares.
kin::JointVector shift_at(const Path& path, const kin::Model& actual, const Reference& ref, const Run& run,
                          std::size_t i, const kin::JointVector& command, const PointPrediction& pp,
                          const PrecompensateOptions& opt) {
  const int n = path.joints;
  // J at the actual joints; the orientation rows keep only what tilts the tool axis.
  const kin::JointVector qa = command - pp.following;
  const kin::Jacobian jac = model_at(path, i, actual).jacobian(qa);
  const Eigen::Vector3d& o = pp.axis;
  const Eigen::Matrix3d tilt = Eigen::Matrix3d::Identity() - o * o.transpose();
  // The tip moves by the normal error vector (its tangential part is zero: the lag along the path
  // stays), the tool axis by the rotation to the intended axis. A machine with fewer joints than
  // these 5 conditions (the X Z B C lathe) may in addition slide the foot by Δs along the path
  // (the intended tip moves by t·Δs and its axis turns by ω·Δs): one more unknown, so tip and
  // axis can both be met. Least squares, minimum norm where redundant.
  const bool slide = n < 5;
  const Slide sl = slide ? slide_at(ref, run, i) : Slide{};
  const int cols = slide ? n + 1 : n;
  Matrix6n a(6, cols);
  a.topLeftCorner(3, n) = jac.topRows<3>();
  a.bottomLeftCorner(3, n) = opt.orientation_length_mm * (tilt * jac.bottomRows<3>());
  if (slide) {
    a.col(n).head<3>() = -sl.tip;
    a.col(n).tail<3>() = -opt.orientation_length_mm * (tilt * sl.turn);
  }
  Eigen::Matrix<double, 6, 1> rhs;
  rhs.head<3>() = pp.error;
  rhs.tail<3>() = opt.orientation_length_mm * (tilt * pp.rotation);
  // Damped normal equations (a 5 × 5 or 6 × 6 solve): least squares, and close to the
  // minimum-norm solution where the machine is redundant; directions weaker than rcond (relative
  // to the strongest) are damped away.
  Square normal = a.transpose() * a;
  const double cut = slide ? std::max(opt.rcond, 1e-3) : opt.rcond;
  normal.diagonal().array() += cut * cut * normal.diagonal().maxCoeff();
  return normal.ldlt().solve(a.transpose() * rhs).head(n);
}

}  // namespace

std::vector<kin::JointVector> lag_precompensation(const Path& path) {
  std::vector<kin::JointVector> c;
  c.reserve(path.points.size());
  for (const PathPoint& p : path.points) c.push_back(p.q);
  std::vector<double> remaining;
  for (const Run& run : path.runs) {
    // The joint-space path length from each point to the run's end: the advance never exceeds
    // half of it, so the commands never run past the run's end point and back (the controller
    // would time that reversal as a move of its own, and the tool would follow it).
    remaining.assign(run.size(), 0.0);
    for (std::size_t i = run.end - 1; i-- > run.begin;)
      remaining[i - run.begin] = remaining[i + 1 - run.begin] + (path.points[i + 1].q - path.points[i].q).norm();
    for (std::size_t i = run.begin; i < run.end; ++i) {
      if (!correctable(path, run, i)) continue;
      const PathPoint &a = path.points[i - 1], &b = path.points[i], &e = path.points[i + 1];
      const double ha = b.t - a.t, hb = e.t - b.t;
      if (!(ha > 0) || !(hb > 0)) continue;
      for (int j = 0; j < path.joints; ++j) {
        const double vin = (b.q[j] - a.q[j]) / ha, vout = (e.q[j] - b.q[j]) / hb;
        const double v = (vin * hb + vout * ha) / (ha + hb);
        const double acc = 2 * (vout - vin) / (ha + hb);
        // c = r + e(c): the command runs with its own following error, so the advance is the
        // drive's lag of the advanced command; to second order e₁·ṙ + (e₂ + e₁²)·r̈ (the
        // quasi-static inverse of the drive; for a lag-mode drive e₂ + e₁² = 0 and this is the
        // exact inverse c = r + ṙ/Kv). Adding e(r) instead would leave −(1 − H)²·r: on a circle
        // twice the original radial error, outward.
        const Drive& dr = path.drives[static_cast<std::size_t>(j)];
        const double e1 = dr.lag(1.0);
        c[i][j] += dr.lag(v, acc) + e1 * e1 * acc;
      }
      const double advance = (c[i] - b.q).norm(), room = 0.5 * remaining[i - run.begin];
      if (advance > room) c[i] = b.q + (room / advance) * (c[i] - b.q);
    }
  }
  return c;
}

Precompensation precompensate(const Path& path, const kin::Model& actual, const Reference& ref,
                              const PrecompensateOptions& opt) {
  Precompensation r;
  r.commands.reserve(path.points.size());
  for (const PathPoint& p : path.points) r.commands.push_back(p.q);
  r.lag_commands = lag_precompensation(path);
  r.before = predict(path, actual, ref, &r.commands);
  const int n = path.joints;
  const double L = opt.orientation_length_mm;
  // The smoothing time: a fraction of the slowest drive's lag time.
  double lag_time = 0;
  for (const Drive& d : path.drives) lag_time = std::max(lag_time, d.lag(1.0));
  const double tau = opt.smoothing * lag_time;

  // The lag precompensation's prediction: a second start for runs where the iteration from the
  // program ends predicted worse than it (below).
  const Prediction lag = predict(path, actual, ref, &r.lag_commands);
  std::vector<PointPrediction> cur = r.before.points, next = r.before.points;
  std::vector<kin::JointVector> trial = r.commands;
  std::vector<kin::JointVector> step(path.points.size(), kin::JointVector::Zero(n));
  std::vector<double> max_following(static_cast<std::size_t>(n), 0.0), column, times;
  std::vector<std::size_t> idx;
  std::vector<kin::JointVector> kept_commands;
  std::vector<PointPrediction> kept_points;
  r.runs.resize(path.runs.size());
  for (std::size_t ri = 0; ri < path.runs.size(); ++ri) {
    if (opt.progress && ri % 64 == 0)
      opt.progress("contour: correcting", static_cast<double>(ri), static_cast<double>(path.runs.size()));
    const Run& run = path.runs[ri];
    RunIteration& it = r.runs[ri];
    RunFigures now = figures(cur, run, L);
    it.before_tip_mm = it.after_tip_mm = now.tip;
    it.before_axis_rad = it.after_axis_rad = now.axis;
    it.before_rms_mm = it.after_rms_mm = now.tip_rms;
    idx.clear();
    times.clear();
    for (std::size_t i = run.begin; i < run.end; ++i)
      if (correctable(path, run, i)) {
        idx.push_back(i);
        times.push_back(path.points[i].t);
      }
    if (idx.empty() || now.score == 0) {
      it.stop = RunStop::nothing;
      continue;
    }
    std::optional<Smoother> smoother;
    if (tau > 0 && idx.size() >= 3) smoother.emplace(times, tau);
    // The iteration of the run from its current commands (r.commands, predicted in cur), with
    // its own step control; returns the kept iterate's figures.
    const auto iterate = [&](RunIteration& log, RunFigures fig) {
      double alpha = 1;
      log.stop = RunStop::cap;
      while (log.iterations < opt.max_iterations) {
        for (std::size_t i : idx) {
          const PointPrediction& pp = cur[i];
          step[i] = pp.tip_mm == 0 && pp.axis_rad == 0 ? kin::JointVector::Zero(n)
                                                       : shift_at(path, actual, ref, run, i, r.commands[i], pp, opt);
        }
        run_step(path, idx, smoother ? &*smoother : nullptr, step, opt.invert_lag, column);
        bool taken = false;
        RunFigures got;
        for (int h = 0; h <= opt.max_halvings; ++h) {
          for (std::size_t i : idx) trial[i] = r.commands[i] + alpha * step[i];
          std::uint64_t unused = 0;
          predict_run(path, actual, ref, trial, run, true, next, max_following, unused);
          ++log.trials;
          got = figures(next, run, L);
          if (improves(got, fig)) {
            taken = true;
            break;
          }
          alpha *= 0.5;
        }
        if (!taken) {
          for (std::size_t i : idx) trial[i] = r.commands[i];
          log.stop = RunStop::no_improvement;
          break;
        }
        for (std::size_t i : idx) r.commands[i] = trial[i];
        std::copy(next.begin() + static_cast<std::ptrdiff_t>(run.begin), next.begin() + static_cast<std::ptrdiff_t>(run.end),
                  cur.begin() + static_cast<std::ptrdiff_t>(run.begin));
        const double gain = fig.score - got.score, gain_rms = fig.rms - got.rms;
        fig = got;
        ++log.iterations;
        log.history_mm.push_back(fig.tip);
        log.history_rad.push_back(fig.axis);
        alpha = std::min(1.0, 2 * alpha);
        if ((gain < opt.tolerance_mm && gain_rms < opt.tolerance_mm) ||
            (gain < opt.relative_tolerance * fig.score && gain_rms < opt.relative_tolerance * fig.rms)) {
          log.stop = RunStop::converged;
          break;
        }
      }
      return fig;
    };
    now = iterate(it, now);
    // Where the lag precompensation is predicted better than that iterate, the iteration is run
    // again from it, and the better of the two iterates is kept.
    if (const RunFigures from_lag = figures(lag.points, run, L); improves(from_lag, now)) {
      kept_commands.assign(r.commands.begin() + static_cast<std::ptrdiff_t>(run.begin),
                           r.commands.begin() + static_cast<std::ptrdiff_t>(run.end));
      kept_points.assign(cur.begin() + static_cast<std::ptrdiff_t>(run.begin),
                         cur.begin() + static_cast<std::ptrdiff_t>(run.end));
      for (std::size_t i = run.begin; i < run.end; ++i) {
        r.commands[i] = r.lag_commands[i];
        cur[i] = lag.points[i];
      }
      RunIteration second;
      const RunFigures again = iterate(second, from_lag);
      if (improves(again, now)) {
        second.before_tip_mm = it.before_tip_mm;
        second.before_axis_rad = it.before_axis_rad;
        second.before_rms_mm = it.before_rms_mm;
        second.trials += it.trials;
        second.from_lag = true;
        it = std::move(second);
        now = again;
      } else {
        std::copy(kept_commands.begin(), kept_commands.end(), r.commands.begin() + static_cast<std::ptrdiff_t>(run.begin));
        std::copy(kept_points.begin(), kept_points.end(), cur.begin() + static_cast<std::ptrdiff_t>(run.begin));
      }
    }
    it.after_tip_mm = now.tip;
    it.after_axis_rad = now.axis;
    it.after_rms_mm = now.tip_rms;
  }

  // The prediction of the kept iterates, assembled from the runs' last accepted predictions.
  r.after.points = std::move(cur);
  r.after.max_following.assign(static_cast<std::size_t>(n), 0.0);
  std::vector<double> tip(path.points.size(), 0.0), axis(path.points.size(), 0.0);
  for (std::size_t i = 0; i < r.after.points.size(); ++i) {
    const PointPrediction& pp = r.after.points[i];
    tip[i] = pp.tip_mm;
    axis[i] = pp.axis_rad;
    for (int j = 0; j < n && j < pp.following.size(); ++j)
      r.after.max_following[static_cast<std::size_t>(j)] =
          std::max(r.after.max_following[static_cast<std::size_t>(j)], std::abs(pp.following[j]));
  }
  r.after.tip = summarise(tip);
  r.after.axis = summarise(axis);
  r.after.unconverged = r.before.unconverged;  // foot searches of the input's prediction

  r.converged = true;
  for (const RunIteration& it : r.runs) {
    r.iterations = std::max(r.iterations, it.iterations);
    if (it.stop == RunStop::cap) r.converged = false;
  }
  for (int k = 0; k < r.iterations; ++k) {
    double mm = 0, rad = 0;
    for (const RunIteration& it : r.runs) {
      if (it.history_mm.empty()) {
        mm = std::max(mm, it.before_tip_mm);
        rad = std::max(rad, it.before_axis_rad);
        continue;
      }
      const std::size_t at = std::min(static_cast<std::size_t>(k), it.history_mm.size() - 1);
      mm = std::max(mm, it.history_mm[at]);
      rad = std::max(rad, it.history_rad[at]);
    }
    r.history_mm.push_back(mm);
    r.history_rad.push_back(rad);
  }
  return r;
}

}  // namespace postproc::contour
