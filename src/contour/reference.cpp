// The intended contour of a path and the contour error of actual poses against it (see reference.hpp).
#include "postproc/contour/reference.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <string>

#include "postproc/error.hpp"

namespace postproc::contour {
namespace {

constexpr std::uint32_t kNoRun = std::numeric_limits<std::uint32_t>::max();
/// A turn of the tip or marker path sharper than this between two moves is a corner: the contour
/// is fitted in spans between corners. Dense CAM output of a smooth surface turns by a few
/// degrees per point at most; a polygon's corners (pockets, coarse programs) turn by more.
constexpr double kCornerDeg = 15.0;

/// Index (into `params`, non-decreasing, non-empty) of the parameter nearest u; on a tie the lower.
std::size_t nearest(const std::vector<double>& params, double u) {
  const auto it = std::upper_bound(params.begin(), params.end(), u);
  std::size_t k = it == params.begin() ? 0 : static_cast<std::size_t>(it - params.begin()) - 1;
  if (k + 1 < params.size() && params[k + 1] - u < u - params[k]) ++k;
  return k;
}

/// Whether a piece's points all share one parameter (its tool points coincide: the piece is an
/// orientation-only stretch and its tip curve is a single point).
bool degenerate(const FitPiece& piece) { return piece.fit.params.front() == piece.fit.params.back(); }

/// Sets the axis part of `e`: intended axis o_star (unit) against the actual axis o_act (unit).
void set_axis(ContourError& e, const Eigen::Vector3d& o_act, const Eigen::Vector3d& o_star) {
  e.axis = o_star;
  const Eigen::Vector3d c = o_act.cross(o_star);
  const double s = c.norm();
  e.angle = std::atan2(s, o_act.dot(o_star));
  e.rotation = s > 0 ? Eigen::Vector3d(c * (e.angle / s)) : Eigen::Vector3d::Zero();
}

}  // namespace

Reference::Reference(const Path& path, const kin::Model& model, const ReferenceOptions& opt) : opt_(opt) {
  if (!(opt_.marker_length_mm > 0) || !std::isfinite(opt_.marker_length_mm))
    throw Error(ExitCode::usage, "contour reference: marker_length_mm must be > 0, got " + std::to_string(opt_.marker_length_mm));
  if (path.runs.size() >= kNoRun) throw Error(ExitCode::internal, "contour reference: too many runs");
  const std::size_t n = path.points.size();
  poses_.resize(n);
  for (std::size_t i = 0; i < n; ++i) {
    const kin::Model& mi = model_at(path, i, model, opt_.nominal);
    const kin::Solve s = kin::forward(mi, path.points[i].q, poses_[i]);
    if (!s.ok())
      throw Error(ExitCode::refused, "contour reference: the forward kinematics of the " + mi.kind() +
                                         " model failed at path point " + std::to_string(i) + " (line " +
                                         std::to_string(path.points[i].line) + "): " + std::string(kin::to_string(s.status)));
  }
  markers_.resize(n);
  for (std::size_t i = 0; i < n; ++i) markers_[i] = poses_[i].p + opt_.marker_length_mm * poses_[i].axis();
  arc_.assign(n, 0.0);
  for (const Run& run : path.runs)
    for (std::size_t i = run.begin + 1; i < run.end && run.end <= n; ++i)
      arc_[i] = arc_[i - 1] + std::max((poses_[i].p - poses_[i - 1].p).norm(), (markers_[i] - markers_[i - 1]).norm());
  run_index_.assign(n, kNoRun);
  runs_.reserve(path.runs.size());
  const double dup = opt_.fit.duplicate_mm;
  const double l = opt_.marker_length_mm;
  std::vector<Eigen::Vector3d> tips, markers;
  for (const Run& run : path.runs) {
    if (run.begin >= run.end || run.end > n)
      throw Error(ExitCode::internal, "contour reference: run [" + std::to_string(run.begin) + ", " +
                                          std::to_string(run.end) + ") outside the path's " + std::to_string(n) + " points");
    path_runs_.push_back(run);
    // Spans: the run cut at corners (a turn of the tip path or of the marker path above
    // kCornerDeg between consecutive moves). A cubic through a corner would overshoot; each
    // span is fitted on its own and the corner point ends one span and starts the next.
    std::size_t span_begin = run.begin;
    for (std::size_t k = run.begin + 1; k < run.end; ++k) {
      const bool last = k + 1 == run.end;
      if (!last && !corner(poses_, k, run.end, l, dup)) continue;
      fit_span(span_begin, k + 1, l, dup, tips, markers);
      span_begin = k;
    }
    if (run.end - run.begin == 1) fit_span(run.begin, run.end, l, dup, tips, markers);
  }
}

bool Reference::corner(const std::vector<kin::Pose>& poses, std::size_t k, std::size_t end, double l, double dup) {
  // The turn at k of one of the two curves (point of pose i: at(i)): from the move ending at k to
  // the first later point that differs from k. Only the first of repeated points is a corner, so
  // a span never holds nothing but copies of one point.
  const auto turn = [&](auto at) {
    const Eigen::Vector3d b = at(k), u = b - at(k - 1);
    if (u.norm() <= dup) return false;
    for (std::size_t j = k + 1; j < end; ++j) {
      const Eigen::Vector3d v = at(j) - b;
      if (v.norm() > dup) return u.normalized().dot(v.normalized()) < std::cos(kCornerDeg * kin::kDeg);
    }
    return false;
  };
  return turn([&](std::size_t i) -> Eigen::Vector3d { return poses[i].p; }) ||
         turn([&](std::size_t i) -> Eigen::Vector3d { return poses[i].p + l * poses[i].axis(); });
}

void Reference::fit_span(std::size_t begin, std::size_t end, double l, double dup, std::vector<Eigen::Vector3d>& tips,
                         std::vector<Eigen::Vector3d>& markers) {
  RunFit f;
  f.begin = begin;
  f.end = end;
  tips.clear();
  markers.clear();
  bool distinct = false;
  for (std::size_t i = begin; i < end; ++i) {
    if (run_index_[i] == kNoRun) run_index_[i] = static_cast<std::uint32_t>(runs_.size());
    tips.push_back(poses_[i].p);
    markers.push_back(poses_[i].p + l * poses_[i].axis());
    distinct = distinct || (tips.back() - tips.front()).norm() > dup || (markers.back() - markers.front()).norm() > dup;
  }
  if (distinct) {
    f.curve = true;
    f.tip = fit_windows(tips, opt_.window, opt_.overlap, opt_.fit);
    f.marker = fit_windows(markers, opt_.window, opt_.overlap, opt_.fit);
    if (f.tip.pieces.size() != f.marker.pieces.size())
      throw Error(ExitCode::internal, "contour reference: tip and marker fits have different windows");
    max_residual_ = std::max({max_residual_, f.tip.max_residual_mm(), f.marker.max_residual_mm()});
    within_ = within_ && f.tip.within_tolerance() && f.marker.within_tolerance();
  }
  runs_.push_back(std::move(f));
}

Run Reference::run(std::size_t r) const {
  if (r >= path_runs_.size())
    throw Error(ExitCode::usage, "contour reference: run " + std::to_string(r) + " out of range (" +
                                     std::to_string(path_runs_.size()) + " runs)");
  return path_runs_[r];
}

const Reference::RunFit* Reference::run_of(std::size_t i) const {
  if (i >= run_index_.size() || run_index_[i] == kNoRun)
    throw Error(ExitCode::usage, "contour reference: path point " + std::to_string(i) + " is not on a run (" +
                                     std::to_string(run_index_.size()) + " points)");
  return &runs_[run_index_[i]];
}

ContourError Reference::error(const kin::Pose& actual, std::size_t hint) const {
  return error(actual, hint, hint, 0.0);
}

ContourError Reference::error(const kin::Pose& actual, std::size_t hint, std::size_t toward, double fraction) const {
  const RunFit* span = run_of(hint);
  ContourError e = error_in(*span, actual, hint, toward, fraction);
  // At a corner the neighbouring span of the same run (which shares the corner point) may hold
  // the nearer foot: where the foot or the place searched from is at the corner (a hint at the
  // corner point belongs to the span before it, while the tool may already be past the corner:
  // the span's curve then has its foot short of the corner, at a false local minimum).
  const auto si = static_cast<std::size_t>(span - runs_.data());
  const bool at_end = e.point + 1 == span->end || hint + 1 == span->end || toward + 1 >= span->end;
  const bool at_begin = e.point == span->begin || hint == span->begin || toward <= span->begin;
  if (at_end && si + 1 < runs_.size() && runs_[si + 1].begin + 1 == span->end) {
    const ContourError f = error_in(runs_[si + 1], actual, span->end - 1, span->end - 1, 0.0);
    if (f.distance < e.distance) e = f;
  }
  if (at_begin && si > 0 && runs_[si - 1].end == span->begin + 1) {
    const ContourError f = error_in(runs_[si - 1], actual, span->begin, span->begin, 0.0);
    if (f.distance < e.distance) e = f;
  }
  return e;
}

double Reference::pose_distance(const kin::Pose& a, const kin::Pose& b) const {
  const Eigen::Vector3d d = a.p - b.p;
  return std::max(d.norm(), (d + opt_.marker_length_mm * (a.axis() - b.axis())).norm());
}

const Run& Reference::path_run_of(std::size_t i) const {
  const auto it = std::upper_bound(path_runs_.begin(), path_runs_.end(), i,
                                   [](std::size_t v, const Run& r) { return v < r.begin; });
  if (it == path_runs_.begin() || i >= (it - 1)->end)
    throw Error(ExitCode::usage, "contour reference: path point " + std::to_string(i) + " is not on a run");
  return *(it - 1);
}

void Reference::chord_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& m, std::size_t k, double& fraction,
                               double& tip2, double& marker2) const {
  const Eigen::Vector3d& a = poses_[k].p;
  const Eigen::Vector3d& ma = markers_[k];
  const Eigen::Vector3d dt = poses_[k + 1].p - a, dm = markers_[k + 1] - ma;
  // The tip decides where the tip moves; on an orientation-only chord (the tip moving much less
  // than the marker point) the marker point does.
  const double lt = dt.squaredNorm(), lm = dm.squaredNorm();
  if (lt > 1e-6 * lm && lt > 0) fraction = std::clamp((p - a).dot(dt) / lt, 0.0, 1.0);
  else if (lm > 0) fraction = std::clamp((m - ma).dot(dm) / lm, 0.0, 1.0);
  else fraction = 0;
  tip2 = (a + fraction * dt - p).squaredNorm();
  marker2 = (ma + fraction * dm - m).squaredNorm();
}

Place Reference::place_on(const kin::Pose& pose, std::size_t k) const {
  const Run& run = path_run_of(k);
  Place place;
  place.point = k;
  if (k + 1 >= run.end) {
    place.arc = arc_[k];
    place.distance = pose_distance(pose, poses_[k]);
    return place;
  }
  double tip2 = 0, marker2 = 0;
  chord_distance(pose.p, pose.p + opt_.marker_length_mm * pose.axis(), k, place.fraction, tip2, marker2);
  place.arc = arc_[k] + place.fraction * (arc_[k + 1] - arc_[k]);
  place.distance = std::sqrt(std::max(tip2, marker2));
  return place;
}

Place Reference::follow(const kin::Pose& pose, const Place& from, double reach) const {
  const Run& run = path_run_of(from.point);
  if (from.point + 1 >= run.end) return place_on(pose, from.point);
  const Eigen::Vector3d m = pose.p + opt_.marker_length_mm * pose.axis();
  Place best = from;
  double best2 = std::numeric_limits<double>::infinity();
  for (std::size_t k = from.point; k + 1 < run.end && (k == from.point || arc_[k] <= from.arc + reach); ++k) {
    double f = 0, tip2 = 0, marker2 = 0;
    chord_distance(pose.p, m, k, f, tip2, marker2);
    if (k == from.point && f < from.fraction) {  // never backward: the distances at the place it had
      f = from.fraction;
      tip2 = (poses_[k].p + f * (poses_[k + 1].p - poses_[k].p) - pose.p).squaredNorm();
      marker2 = (markers_[k] + f * (markers_[k + 1] - markers_[k]) - m).squaredNorm();
    }
    const double d2 = std::max(tip2, marker2);
    if (d2 < best2) {
      best2 = d2;
      best.point = k;
      best.fraction = f;
    }
  }
  best.arc = arc_[best.point] + best.fraction * (arc_[best.point + 1] - arc_[best.point]);
  best.distance = std::sqrt(best2);
  return best;
}

ContourError Reference::error_within(const kin::Pose& actual, const Place& around, double lo, double hi) const {
  const Run& run = path_run_of(around.point);
  if (run.size() == 1) return error(actual, run.begin);
  // The stretch [a, b]: from the last point at or before lo to the first at or after hi.
  std::size_t a = around.point, b = std::min(around.point + 1, run.end - 1);
  while (a > run.begin && arc_[a] > lo) --a;
  while (b + 1 < run.end && arc_[b] < hi) ++b;
  // Its nearest chord: by the tool tip, and among chords as near (an orientation-only stretch,
  // coincident tips) by the marker point.
  const Eigen::Vector3d m = actual.p + opt_.marker_length_mm * actual.axis();
  std::size_t k = a;
  double t = 0, best_tip2 = std::numeric_limits<double>::infinity(), best_marker2 = best_tip2;
  for (std::size_t i = a; i < b; ++i) {
    double f = 0, tip2 = 0, marker2 = 0;
    chord_distance(actual.p, m, i, f, tip2, marker2);
    const bool tie = std::abs(tip2 - best_tip2) <= 1e-12 * (1 + best_tip2);
    if (tie ? marker2 < best_marker2 : tip2 < best_tip2) {
      best_tip2 = tip2;
      best_marker2 = marker2;
      k = i;
      t = f;
    }
  }
  // The fitted curve from there (its foot is continuous; the chords are the controller's moves
  // between the points, the curve the contour meant).
  ContourError e = t <= 0.5 ? error(actual, k, k + 1, t) : error(actual, k + 1, k, 1 - t);
  // The curve's local foot must stay at that chord (its points or their neighbours) and in the
  // stretch; if it slid elsewhere (a farther local minimum, a neighbouring pass nearer in space
  // but not where the tool is), the chord's foot stands.
  if (e.point >= std::max(a, k > 0 ? k - 1 : 0) && e.point <= std::min(b, k + 2)) return e;
  const kin::Pose &p0 = poses_[k], &p1 = poses_[k + 1];
  e = ContourError{};
  e.foot = p0.p + t * (p1.p - p0.p);
  e.vector = e.foot - actual.p;
  e.distance = e.vector.norm();
  e.point = t <= 0.5 ? k : k + 1;
  const Eigen::Vector3d o = (1 - t) * p0.axis() + t * p1.axis();
  set_axis(e, actual.axis(), o.norm() > 0 ? Eigen::Vector3d(o.normalized()) : p0.axis());
  return e;
}

ContourError Reference::error_in(const RunFit& run, const kin::Pose& actual, std::size_t hint, std::size_t toward,
                                  double fraction) const {
  const Eigen::Vector3d o_act = actual.axis();
  ContourError e;
  if (!run.curve) {  // a single pose: plain distances
    const kin::Pose& ref = poses_[run.begin];
    e.foot = ref.p;
    e.vector = ref.p - actual.p;
    e.distance = e.vector.norm();
    e.point = run.begin;
    e.u = 0;
    set_axis(e, o_act, ref.axis());
    return e;
  }

  // Tool tip: the foot on the tip curve of the piece where the hint is most central; when the foot
  // lies nearer points another piece is more central for (or stops at a piece's free end inside
  // the run), again on that piece. Bounded, and the closest answer is kept if it does not settle.
  const std::size_t n = run.end - run.begin;
  const WindowedFit& tip = run.tip;
  std::size_t local = hint - run.begin;
  const FitPiece* piece = &tip.piece_for(local);
  const FitPiece* previous = nullptr;
  double u0 = piece->param(local);
  if (fraction > 0 && toward != hint && toward >= run.begin) {
    const std::size_t other = toward - run.begin;
    if (other >= piece->begin && other < piece->end) u0 += fraction * (piece->param(other) - u0);
  }
  ProjectResult foot;
  const FitPiece* foot_piece = nullptr;
  for (int attempt = 0; attempt < 4; ++attempt) {
    ProjectResult r;
    if (degenerate(*piece)) {  // one tool point: the curve is that point
      r.u = piece->fit.params.front();
      r.point = piece->fit.curve.point(r.u);
      r.distance = (r.point - actual.p).norm();
      r.converged = true;
    } else {
      r = project(piece->fit.curve, actual.p, u0);
    }
    if (foot_piece == nullptr || r.distance <= foot.distance) {
      foot = r;
      foot_piece = piece;
    }
    // Where the foot is: the point nearest it, and the piece that point belongs to.
    std::size_t k = piece->begin + nearest(piece->fit.params, r.u);
    const FitPiece* next = &tip.piece_for(k);
    if (next == piece) {
      const CubicCurve::Domain dom = piece->fit.curve.domain();
      if (r.u <= dom.begin && piece->begin > 0) {
        k = piece->begin - 1;
        next = &tip.piece_for(k);
      } else if (r.u >= dom.end && piece->end < n) {
        k = piece->end;
        next = &tip.piece_for(k);
      }
    }
    if (next == piece) {  // settled: this piece is the one for the foot's point
      foot = r;
      foot_piece = piece;
      break;
    }
    if (next == previous) break;  // ping-pong across a boundary: keep the closer
    previous = piece;
    piece = next;
    u0 = piece->param(k);
  }

  const FitPiece& tp = *foot_piece;
  const std::vector<double>& pt = tp.fit.params;
  const std::size_t j = static_cast<std::size_t>(foot_piece - tip.pieces.data());
  const FitPiece& mp = run.marker.pieces[j];
  const std::vector<double>& pm = mp.fit.params;
  const double u = foot.u;
  e.foot = foot.point;
  e.vector = foot.point - actual.p;
  e.distance = e.vector.norm();
  e.u = u;
  e.converged = foot.converged;

  // Tool axis: the marker curve's parameter at the same place. Nearest point k; when it is one of
  // several coincident tool points (an orientation-only stretch), the tip parameter says nothing
  // about the orientation, so the actual marker point is projected onto the marker curve.
  const std::size_t k = nearest(pt, u);
  std::size_t a = k, b = k;  // the group of points sharing k's parameter
  while (a > 0 && pt[a - 1] == pt[k]) --a;
  while (b + 1 < pt.size() && pt[b + 1] == pt[k]) ++b;
  double v = 0;
  std::size_t point = k;
  if (a == b) {
    std::size_t lo = k;  // pt[lo] ≤ u ≤ pt[lo + 1]
    if (u < pt[k] && k > 0) lo = k - 1;
    if (lo + 1 >= pt.size()) lo = pt.size() - 2;
    const double span = pt[lo + 1] - pt[lo];
    const double f = span > 0 ? std::clamp((u - pt[lo]) / span, 0.0, 1.0) : 0.0;
    v = pm[lo] + f * (pm[lo + 1] - pm[lo]);
  } else {
    const Eigen::Vector3d q = actual.p + opt_.marker_length_mm * o_act;
    const std::size_t h = std::clamp(hint - run.begin, tp.begin + a, tp.begin + b) - tp.begin;
    const ProjectResult m = project(mp.fit.curve, q, pm[h]);
    v = m.u;
    point = std::clamp(nearest(pm, v), a, b);
    e.converged = e.converged && m.converged;
  }
  e.point = tp.begin + point + run.begin;
  const Eigen::Vector3d d = mp.fit.curve.point(v) - foot.point;
  const double dn = d.norm();
  set_axis(e, o_act, dn > 0 ? Eigen::Vector3d(d / dn) : poses_[e.point].axis());
  return e;
}

Summary summarise(const std::vector<double>& values) {
  Summary s;
  s.count = values.size();
  if (values.empty()) return s;
  double sum2 = 0;
  for (std::size_t i = 0; i < values.size(); ++i) {
    const double x = values[i];
    sum2 += x * x;
    if (i == 0 || x > s.max) {
      s.max = x;
      s.worst = i;
    }
  }
  s.rms = std::sqrt(sum2 / static_cast<double>(values.size()));
  // Nearest rank: the ⌈0.95·n⌉-th smallest (integer arithmetic, no rounding at n = 20, 100 …).
  std::vector<double> sorted(values);
  const std::size_t rank = (95 * sorted.size() + 99) / 100;
  const auto nth = sorted.begin() + static_cast<std::ptrdiff_t>(rank - 1);
  std::nth_element(sorted.begin(), nth, sorted.end());
  s.p95 = *nth;
  return s;
}

}  // namespace postproc::contour
