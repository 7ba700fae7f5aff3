// Following-error and contour-error prediction (document 004).
#include "postproc/contour/predict.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "postproc/error.hpp"

namespace postproc::contour {

namespace {

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

void predict_run(const Path& path, const kin::Model& actual, const Reference& ref,
                 const std::vector<kin::JointVector>& commands, const Run& run, bool retime,
                 std::vector<PointPrediction>& points, std::vector<double>& max_following, std::uint64_t& unconverged) {
  kin::JointVector qa;
  std::array<ErrorState, kin::kMaxJoints> state{};
  std::array<double, kin::kMaxJoints> w_prev{};
  std::array<Piece, 5> cuts{};
  // The run starts at rest with no following error; between points the commands move at a
  // constant velocity, and each drive's error evolves exactly (drive.hpp).
  for (std::size_t i = run.begin; i < run.end; ++i) {
    PointPrediction& pp = points[i];
    pp.following.resize(path.joints);
    double dt = i > run.begin ? path.points[i].t - path.points[i - 1].t : 0.0;
    // Corrected axis values change a move's length in the combined-axes feed metric, and so the
    // time the controller gives it (the joints of an axis program are its axes).
    if (dt > 0 && retime && path.combined_feed && !path.maps.empty() &&
        path.maps[path.points[i].map].form() == machine::Form::axes) {
      const double was = (path.points[i].q - path.points[i - 1].q).norm();
      const double now = (commands[i] - commands[i - 1]).norm();
      if (was > 1e-12) dt *= now / was;
    }
    const std::size_t pieces = dt > 0 ? profile_pieces(path.segments[i], dt, cuts) : 0;
    for (int j = 0; j < path.joints; ++j) {
      const auto ju = static_cast<std::size_t>(j);
      const Drive& drive = path.drives[ju];
      const double dq = pieces > 0 ? commands[i][j] - commands[i - 1][j] : 0.0;
      for (std::size_t k = 0; k < pieces; ++k) {
        const double w = dq * cuts[k].fraction / cuts[k].seconds;
        velocity_jump(drive, state[ju], w - w_prev[ju]);
        propagate(drive, state[ju], w, cuts[k].seconds);
        w_prev[ju] = w;
      }
      pp.following[j] = state[ju].e;
      if (ju < max_following.size()) max_following[ju] = std::max(max_following[ju], std::abs(state[ju].e));
    }
    qa = commands[i] - pp.following;
    kin::Pose pose;
    if (!model_at(path, i, actual).forward(qa, pose).ok()) {
      ++unconverged;
      pp.tip_mm = pp.axis_rad = 0;
      continue;
    }
    const ContourError ce = ref.error(pose, i);
    if (!ce.converged) ++unconverged;
    pp.tip = pose.p;
    pp.axis = pose.axis();
    pp.error = ce.vector;
    pp.tip_mm = ce.distance;
    pp.axis_rad = ce.angle;
    pp.rotation = ce.rotation;
  }
}

Prediction predict(const Path& path, const kin::Model& actual, const Reference& ref,
                   const std::vector<kin::JointVector>* commands) {
  std::vector<kin::JointVector> own;
  const bool retime = commands != nullptr;
  if (commands == nullptr) {
    own.reserve(path.points.size());
    for (const PathPoint& p : path.points) own.push_back(p.q);
    commands = &own;
  }
  if (commands->size() != path.points.size())
    throw Error(ExitCode::internal, "predict: one command per path point is required");
  if (path.joints < 0 || path.joints > kin::kMaxJoints) throw Error(ExitCode::internal, "predict: too many joints");
  Prediction out;
  out.points.resize(path.points.size());
  out.max_following.assign(static_cast<std::size_t>(path.joints), 0.0);
  for (const Run& run : path.runs)
    predict_run(path, actual, ref, *commands, run, retime, out.points, out.max_following, out.unconverged);
  std::vector<double> tip(path.points.size(), 0.0), axis(path.points.size(), 0.0);
  for (std::size_t i = 0; i < out.points.size(); ++i) {
    tip[i] = out.points[i].tip_mm;
    axis[i] = out.points[i].axis_rad;
  }
  out.tip = summarise(tip);
  out.axis = summarise(axis);
  return out;
}

}  // namespace postproc::contour
