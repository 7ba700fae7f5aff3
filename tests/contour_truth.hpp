#pragma once
// A small time-domain "truth" simulator for the contour tests (issue 17), independent of the code
// under test (contour/predict, precompensate, drive, simulate, reference): every joint is a
// first-order lag with velocity feed-forward, ẏ = Kv·(r − y) + f·ṙ, integrated by classic RK4 with
// a fine fixed step over commands that move linearly in time from one path point to the next; the
// tool tip comes from the machine model's forward kinematics (kin::Model, not under test); the
// contour error is the distance of the tip to the intended contour of the ORIGINAL program: a
// centripetal Catmull–Rom curve through its tool points (straight at corners), searched in a
// window that follows the tip along the run.
//
// What it shares with postproc: the commanded points and their times (contour::build_path: the
// controller's reading of the program and its feed timing), the drives' Kv and f from the machine
// file, and kin::Model (and, with TruthOptions::tip_interpolation, the controller map's inverse). What it does not: the speed profile inside a move (here constant), the
// acceleration feed-forward and the velocity loop (not modelled here), the exact discretisation,
// the NURBS reference and its foot search.
#include <algorithm>
#include <cmath>
#include <cstddef>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "postproc/contour/path.hpp"

namespace pptruth {

namespace ct = postproc::contour;
namespace kin = postproc::kin;

struct Truth {
  double max_mm = 0;                ///< largest tool-tip contour error over the program
  double rms_mm = 0;                ///< RMS over every measured sample
  std::vector<double> run_max_mm;   ///< per run
  std::vector<double> run_rms_mm;   ///< per run
  std::size_t samples = 0;
};

struct TruthOptions {
  double step_s = 1e-4;      ///< integration step
  int measure_every = 10;    ///< measure every k-th step (1 ms)
  double settle_s = 0.15;    ///< measured at rest after a run's last point
  int subdivide = 8;         ///< sub-points per segment of the intended contour
  bool curve = true;         ///< a smooth curve through the tool points (false: their polyline)
  double corner_deg = 15;    ///< a turn of more than this at a point is a corner (straight lines there)
  bool nominal = false;      ///< the intended points through the nominal model (--mode all)
  /// Tool-tip programs (G43.4, TRAORI: a controller map of tool-tip form) interpolated as the
  /// controller does, the tool tip and the tool axis linear between the points and the joints
  /// from the controller map's inverse (machine::ProgramMap::joints, the program's reading, not the
  /// code under test). Without it every program's joints move linearly between the points, and the
  /// commanded tip of a tool-tip program leaves its chords where rotary axes move.
  bool tip_interpolation = false;
};

/// Distance from p to segment [a, b].
inline double segment_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double l2 = ab.squaredNorm();
  const double s = l2 > 0 ? std::clamp((p - a).dot(ab) / l2, 0.0, 1.0) : 0.0;
  return (a + s * ab - p).norm();
}

/// Simulates `commanded` and measures against the intended polyline of `original` (same runs).
inline Truth simulate_truth(const ct::Path& commanded, const ct::Path& original, const kin::Model& actual,
                            const TruthOptions& opt = {}) {
  Truth out;
  EXPECT_EQ(commanded.runs.size(), original.runs.size());
  if (commanded.runs.size() != original.runs.size()) return out;
  const int nj = commanded.joints;
  double sum_all = 0;
  for (std::size_t r = 0; r < commanded.runs.size(); ++r) {
    const ct::Run& run = commanded.runs[r];
    const ct::Run& orun = original.runs[r];
    // The intended contour of the original run: its tool points P_i (the commands through the
    // model), joined by centripetal Catmull–Rom pieces where the path turns by less than
    // `corner_deg` at both ends of a segment and by straight lines at corners (the controller
    // moves straight into and out of a corner), subdivided into a dense polyline.
    std::vector<Eigen::Vector3d> tips;
    for (std::size_t i = orun.begin; i < orun.end; ++i) {
      kin::Pose pose;
      const bool ok = ct::model_at(original, i, actual, opt.nominal).forward(original.points[i].q, pose).ok();
      EXPECT_TRUE(ok);
      if (tips.empty() || (pose.p - tips.back()).norm() > 1e-9) tips.push_back(pose.p);
    }
    const auto turn = [&](std::size_t i) {  // turning angle at tips[i], degrees (0 at the ends)
      if (i == 0 || i + 1 >= tips.size()) return 0.0;
      const Eigen::Vector3d a = (tips[i] - tips[i - 1]).normalized(), b = (tips[i + 1] - tips[i]).normalized();
      return std::acos(std::clamp(a.dot(b), -1.0, 1.0)) * 180 / kin::kPi;
    };
    std::vector<Eigen::Vector3d> line{tips.front()};
    for (std::size_t i = 1; i < tips.size(); ++i) {
      const Eigen::Vector3d &p1 = tips[i - 1], &p2 = tips[i];
      const bool smooth = opt.curve && i >= 2 && i + 1 < tips.size() && turn(i - 1) < opt.corner_deg && turn(i) < opt.corner_deg;
      for (int k = 1; k <= opt.subdivide; ++k) {
        const double u = static_cast<double>(k) / opt.subdivide;
        if (!smooth) {
          line.push_back(p1 + u * (p2 - p1));
          continue;
        }
        // Centripetal Catmull–Rom (Barry–Goldman pyramid) through p0 p1 p2 p3, between p1 and p2.
        const Eigen::Vector3d &p0 = tips[i - 2], &p3 = tips[i + 1];
        const double t0 = 0, t1 = t0 + std::sqrt((p1 - p0).norm()), t2 = t1 + std::sqrt((p2 - p1).norm()),
                     t3 = t2 + std::sqrt((p3 - p2).norm());
        const double t = t1 + u * (t2 - t1);
        const Eigen::Vector3d a1 = (t1 - t) / (t1 - t0) * p0 + (t - t0) / (t1 - t0) * p1;
        const Eigen::Vector3d a2 = (t2 - t) / (t2 - t1) * p1 + (t - t1) / (t2 - t1) * p2;
        const Eigen::Vector3d a3 = (t3 - t) / (t3 - t2) * p2 + (t - t2) / (t3 - t2) * p3;
        const Eigen::Vector3d b1 = (t2 - t) / (t2 - t0) * a1 + (t - t0) / (t2 - t0) * a2;
        const Eigen::Vector3d b2 = (t3 - t) / (t3 - t1) * a2 + (t - t1) / (t3 - t1) * a3;
        line.push_back((t2 - t) / (t2 - t1) * b1 + (t - t1) / (t2 - t1) * b2);
      }
    }
    // Drives (Kv, velocity feed-forward) and the run's commands.
    std::vector<double> kv(static_cast<std::size_t>(nj)), ff(static_cast<std::size_t>(nj));
    for (int j = 0; j < nj; ++j) {
      kv[static_cast<std::size_t>(j)] = commanded.drives[static_cast<std::size_t>(j)].kv;
      ff[static_cast<std::size_t>(j)] = commanded.drives[static_cast<std::size_t>(j)].feed_forward;
    }
    const bool feed_forward = std::any_of(ff.begin(), ff.end(), [](double f) { return f != 0; });
    const double t0 = commanded.points[run.begin].t;
    const double t_end = commanded.points[run.end - 1].t - t0;
    // r(t), ṙ(t): linear between the run's points.
    std::size_t seg = run.begin + 1;
    const auto command = [&](double t, kin::JointVector& rq, kin::JointVector& rv, std::size_t& at) {
      if (t >= t_end || run.size() < 2) {
        rq = commanded.points[run.end - 1].q;
        rv.setZero(nj);
        at = run.end - 1;
        return;
      }
      while (seg + 1 < run.end && commanded.points[seg].t - t0 <= t) ++seg;
      const ct::PathPoint& a = commanded.points[seg - 1];
      const ct::PathPoint& b = commanded.points[seg];
      const double h = b.t - a.t;
      const double s = h > 0 ? std::clamp((t - (a.t - t0)) / h, 0.0, 1.0) : 1.0;
      rq = a.q + s * (b.q - a.q);
      rv = h > 0 ? kin::JointVector((b.q - a.q) / h) : kin::JointVector::Zero(nj);
      at = seg;
      if (opt.tip_interpolation && !commanded.maps.empty() && commanded.maps[b.map].form() != postproc::machine::Form::axes &&
          s > 0 && s < 1) {
        const postproc::machine::ProgramMap& map = commanded.maps[b.map];
        const auto joints_at = [&](double f, kin::JointVector& q) {
          postproc::machine::Command c;
          c.c = a.command.c + f * (b.command.c - a.command.c);
          c.vector = (a.command.vector + f * (b.command.vector - a.command.vector)).normalized();
          const kin::JointVector guess = a.q + f * (b.q - a.q);  // picks the branch
          if (!map.joints(c, guess, q).ok()) q = guess;
        };
        joints_at(s, rq);
        if (feed_forward && h > 0) {  // the rate by a forward difference over 1 µs
          const double ds = std::min(1e-6 / h, 1 - s);
          kin::JointVector q2(nj);
          joints_at(s + ds, q2);
          rv = (q2 - rq) / (ds * h);
        }
      }
    };
    kin::JointVector y = commanded.points[run.begin].q, rq(nj), rv(nj);
    std::size_t at = run.begin;
    const auto deriv = [&](double t, const kin::JointVector& yy) {
      command(t, rq, rv, at);
      kin::JointVector d(nj);
      for (int j = 0; j < nj; ++j)
        d[j] = kv[static_cast<std::size_t>(j)] * (rq[j] - yy[j]) + ff[static_cast<std::size_t>(j)] * rv[j];
      return d;
    };
    std::size_t hint = 0;
    double run_max = 0, run_sum = 0;
    std::size_t run_n = 0;
    const double h = opt.step_s;
    const auto steps = static_cast<long>(std::ceil((t_end + opt.settle_s) / h));
    for (long k = 1; k <= steps; ++k) {
      const double t = static_cast<double>(k - 1) * h;
      // Classic RK4; the segment search only moves forward, so the stages are evaluated in order
      // of time (t, t + h/2, t + h/2, t + h).
      const kin::JointVector k1 = deriv(t, y);
      const kin::JointVector k2 = deriv(t + h / 2, y + h / 2 * k1);
      const kin::JointVector k3 = deriv(t + h / 2, y + h / 2 * k2);
      const kin::JointVector k4 = deriv(t + h, y + h * k3);
      y += h / 6 * (k1 + 2 * k2 + 2 * k3 + k4);
      if (k % opt.measure_every != 0) continue;
      kin::Pose pose;
      if (!ct::model_at(commanded, at, actual).forward(y, pose).ok()) {
        ADD_FAILURE() << "truth: forward kinematics failed";
        return out;
      }
      // Nearest point of the polyline in a window from a little behind the last foot to a little
      // beyond the command (the tool lags its command: the foot cannot run ahead of it, which
      // keeps the search on the right pass where the path crosses itself).
      const std::size_t ahead = (at - run.begin + 3) * static_cast<std::size_t>(opt.subdivide);
      const std::size_t lo = hint > 80 ? hint - 80 : 0;
      const std::size_t hi = std::max(lo + 1, std::min(line.size() - 1, ahead));
      double best = line.size() == 1 ? (pose.p - line[0]).norm() : 1e300;
      std::size_t best_i = hint;
      for (std::size_t i = lo; i < hi; ++i) {
        const double d = segment_distance(pose.p, line[i], line[i + 1]);
        if (d < best) {
          best = d;
          best_i = i;
        }
      }
      hint = best_i;
      run_max = std::max(run_max, best);
      run_sum += best * best;
      ++run_n;
    }
    out.run_max_mm.push_back(run_max);
    out.run_rms_mm.push_back(run_n > 0 ? std::sqrt(run_sum / static_cast<double>(run_n)) : 0.0);
    out.max_mm = std::max(out.max_mm, run_max);
    sum_all += run_sum;
    out.samples += run_n;
  }
  out.rms_mm = out.samples > 0 ? std::sqrt(sum_all / static_cast<double>(out.samples)) : 0.0;
  return out;
}

}  // namespace pptruth
