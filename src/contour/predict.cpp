// Following-error and contour-error prediction (document 004) and contour precompensation.
#include "postproc/contour/predict.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include <Eigen/Cholesky>

#include "postproc/error.hpp"

namespace postproc::contour {

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

/// One piece of a segment's speed profile: its duration and the share of the segment covered.
struct Piece {
  double seconds = 0;
  double fraction = 0;
};

/// The segment's speed profile (path.hpp: accelerate, cruise, decelerate) as pieces of constant
/// velocity for the drive model: each acceleration phase in two halves at their mean speeds, the
/// cruise as one. Returns the number of pieces written to `out` (≤ 5).
std::size_t profile_pieces(const SegmentProfile& s, double dt, std::array<Piece, 5>& out) {
  const double A = s.accel;
  // No acceleration limit (path.cpp gives such moves 1e12 mm/s²): one piece at the mean speed.
  if (!(s.length > 0) || !(A > 0) || !std::isfinite(A) || A >= 1e11) {
    out[0] = {dt, 1.0};
    return 1;
  }
  const double vp = s.v_cruise;
  const double ta = std::max(0.0, (vp - s.v_start) / A);
  const double td = std::max(0.0, (vp - s.v_end) / A);
  const double tc = std::max(0.0, dt - ta - td);
  std::size_t n = 0;
  const auto ramp = [&](double v0, double a, double t) {  // two halves of a ramp from v0 at a
    for (int h = 0; h < 2; ++h) {
      const double t0 = 0.5 * t * h, t1 = 0.5 * t * (h + 1);
      const double dist = v0 * (t1 - t0) + 0.5 * a * (t1 * t1 - t0 * t0);
      if (t1 > t0) out[n++] = {t1 - t0, dist / s.length};
    }
  };
  if (ta > 0) ramp(s.v_start, A, ta);
  if (tc > 0) out[n++] = {tc, vp * tc / s.length};
  if (td > 0) ramp(vp, -A, td);
  // The pieces cover the segment exactly: rescale the shares for rounding.
  double sum = 0;
  for (std::size_t k = 0; k < n; ++k) sum += out[k].fraction;
  if (n == 0 || !(sum > 0)) {
    out[0] = {dt, 1.0};
    return 1;
  }
  for (std::size_t k = 0; k < n; ++k) out[k].fraction /= sum;
  return n;
}

}  // namespace

Prediction predict(const Path& path, const kin::Model& actual, const Reference& ref,
                   const std::vector<kin::JointVector>* commands) {
  std::vector<kin::JointVector> own;
  if (commands == nullptr) {
    own.reserve(path.points.size());
    for (const PathPoint& p : path.points) own.push_back(p.q);
    commands = &own;
  }
  if (commands->size() != path.points.size())
    throw Error(ExitCode::internal, "predict: one command per path point is required");
  Prediction out;
  out.points.resize(path.points.size());
  out.max_following.assign(static_cast<std::size_t>(path.joints), 0.0);
  std::vector<double> tip(path.points.size(), 0.0), axis(path.points.size(), 0.0);
  kin::JointVector qa;
  std::vector<ErrorState> state(static_cast<std::size_t>(path.joints));
  std::vector<double> w_prev(static_cast<std::size_t>(path.joints));
  std::array<Piece, 5> cuts{};
  for (const Run& run : path.runs) {
    // Every run starts at rest with no following error; between points the commands move at a
    // constant velocity, and each drive's error evolves exactly (drive.hpp).
    std::fill(state.begin(), state.end(), ErrorState{});
    std::fill(w_prev.begin(), w_prev.end(), 0.0);
    for (std::size_t i = run.begin; i < run.end; ++i) {
      PointPrediction& pp = out.points[i];
      pp.following.resize(path.joints);
      double dt = i > run.begin ? path.points[i].t - path.points[i - 1].t : 0.0;
      // Corrected axis values change a move's length in the combined-axes feed metric, and so the
      // time the controller gives it (the joints of an axis program are its axes).
      if (dt > 0 && commands != &own && path.combined_feed && !path.maps.empty() &&
          path.maps[path.points[i].map].form() == comp::Form::axes) {
        const double was = (path.points[i].q - path.points[i - 1].q).norm();
        const double now = ((*commands)[i] - (*commands)[i - 1]).norm();
        if (was > 1e-12) dt *= now / was;
      }
      const std::size_t pieces = dt > 0 ? profile_pieces(path.segments[i], dt, cuts) : 0;
      for (int j = 0; j < path.joints; ++j) {
        const auto ju = static_cast<std::size_t>(j);
        const Drive& drive = path.drives[ju];
        const double dq = pieces > 0 ? (*commands)[i][j] - (*commands)[i - 1][j] : 0.0;
        for (std::size_t k = 0; k < pieces; ++k) {
          const double w = dq * cuts[k].fraction / cuts[k].seconds;
          velocity_jump(drive, state[ju], w - w_prev[ju]);
          propagate(drive, state[ju], w, cuts[k].seconds);
          w_prev[ju] = w;
        }
        pp.following[j] = state[ju].e;
        out.max_following[ju] = std::max(out.max_following[ju], std::abs(state[ju].e));
      }
      qa = (*commands)[i] - pp.following;
      kin::Pose pose;
      if (!model_at(path, i, actual).forward(qa, pose).ok()) {
        ++out.unconverged;
        continue;
      }
      const ContourError ce = ref.error(pose, i);
      if (!ce.converged) ++out.unconverged;
      pp.tip = pose.p;
      pp.axis = pose.axis();
      pp.error = ce.vector;
      pp.tip_mm = ce.distance;
      pp.axis_rad = ce.angle;
      pp.rotation = ce.rotation;
      tip[i] = ce.distance;
      axis[i] = ce.angle;
    }
  }
  out.tip = summarise(tip);
  out.axis = summarise(axis);
  return out;
}

Precompensation precompensate(const Path& path, const kin::Model& actual, const Reference& ref,
                              const PrecompensateOptions& opt) {
  Precompensation r;
  r.commands.reserve(path.points.size());
  for (const PathPoint& p : path.points) r.commands.push_back(p.q);
  r.before = predict(path, actual, ref, &r.commands);
  Prediction current = r.before;
  std::vector<kin::JointVector> trial;
  const int n = path.joints;
  std::vector<kin::JointVector> shift(path.points.size(), kin::JointVector::Zero(n));
  std::vector<bool> solved(path.points.size(), false);
  using Matrix6n = Eigen::Matrix<double, 6, Eigen::Dynamic, Eigen::ColMajor, 6, kin::kMaxJoints + 1>;
  for (int it = 1; it <= opt.max_iterations; ++it) {
    if (opt.progress) opt.progress("contour: correcting", it - 1, opt.max_iterations);
    trial = r.commands;
    for (auto& d : shift) d.setZero(n);
    std::fill(solved.begin(), solved.end(), false);
    for (const Run& run : path.runs)
      for (std::size_t i = run.begin; i < run.end; ++i) {
        const PathPoint& p = path.points[i];
        // Not the run's last point: the machine comes to rest there and settles on its command,
        // so a correction made for the lag in motion would stay as an error.
        if (!p.block_end || p.run_start || i + 1 == run.end) continue;
        const PointPrediction& pp = current.points[i];
        if (pp.tip_mm == 0 && pp.axis_rad == 0) continue;
        // J at the actual joints; the orientation rows keep only what tilts the tool axis.
        const kin::JointVector qa = r.commands[i] - pp.following;
        const kin::Model& model = model_at(path, i, actual);
        const kin::Jacobian jac = model.jacobian(qa);
        const Eigen::Vector3d& o = pp.axis;
        const Eigen::Matrix3d tilt = Eigen::Matrix3d::Identity() - o * o.transpose();
        // The actual pose is moved onto the intended pose at the foot: the tip by the normal error
        // vector (its tangential part is zero: the lag along the path stays), the tool axis by the
        // rotation to the intended axis. A machine with fewer joints than these 5 conditions (the
        // X Z B C lathe) may in addition slide the foot by Δs along the path (the intended tip
        // moves by t·Δs and its axis turns by ω·Δs): one more unknown, so tip and axis can both
        // be met. Least squares, minimum norm where redundant.
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
        // minimum-norm solution where the machine is redundant; directions weaker than rcond
        // (relative to the strongest) are damped away.
        using Square = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kin::kMaxJoints + 1,
                                     kin::kMaxJoints + 1>;
        Square normal = a.transpose() * a;
        const double cut = slide ? std::max(opt.rcond, 1e-3) : opt.rcond;
        normal.diagonal().array() += cut * cut * normal.diagonal().maxCoeff();
        shift[i] = normal.ldlt().solve(a.transpose() * rhs).head(n);
        solved[i] = true;
      }
    // The shift is wanted in the actual joints; the drives lag the commands, so the commands take
    // the shift plus its own lag (the servo model inverted for a slowly varying shift:
    // δ = d + e₁·ḋ), which lets the iteration converge in a few steps.
    if (opt.invert_lag)
      for (const Run& run : path.runs)
        for (std::size_t i = run.begin + 1; i + 1 < run.end; ++i) {
          if (!solved[i]) continue;
          // Neighbours without a correction of their own (run ends, arc chord points) do not
          // count: a one-sided difference there, not a kick toward zero.
          const std::size_t lo = solved[i - 1] ? i - 1 : i;
          const std::size_t hi = solved[i + 1] ? i + 1 : i;
          const double dt = path.points[hi].t - path.points[lo].t;
          if (dt <= 0) continue;
          for (int j = 0; j < n; ++j) {
            const Drive& dr = path.drives[static_cast<std::size_t>(j)];
            trial[i][j] += dr.lag((shift[hi][j] - shift[lo][j]) / dt);
          }
        }
    for (std::size_t i = 0; i < trial.size(); ++i) trial[i] += shift[i];
    Prediction next = predict(path, actual, ref, &trial);
    // One figure for the iteration: the largest tip error plus L × the largest axis error (mm).
    const auto score = [&](const Prediction& p) { return p.tip.max + opt.orientation_length_mm * p.axis.max; };
    const double gain = score(current) - score(next);
    if (gain <= 0) {
      r.converged = true;  // no further improvement: keep the previous commands
      break;
    }
    r.commands = trial;
    current = std::move(next);
    r.iterations = it;
    r.history_mm.push_back(current.tip.max);
    r.history_rad.push_back(current.axis.max);
    if (gain < opt.tolerance_mm || gain < opt.relative_tolerance * score(current)) {
      r.converged = true;
      break;
    }
  }
  r.after = std::move(current);
  return r;
}

}  // namespace postproc::contour
