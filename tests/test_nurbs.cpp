// Cubic B-spline fitting, windowing and foot points for the contour error of document 004.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <numbers>
#include <random>
#include <vector>

#include "postproc/contour/nurbs.hpp"
#include "postproc/error.hpp"

namespace {

namespace ct = postproc::contour;
using Eigen::Vector3d;
using Curve = std::function<Vector3d(double)>;

std::vector<Vector3d> sample(const Curve& c, double t0, double t1, std::size_t n) {
  std::vector<Vector3d> out;
  out.reserve(n);
  for (std::size_t i = 0; i < n; ++i) out.push_back(c(t0 + (t1 - t0) * static_cast<double>(i) / static_cast<double>(n - 1)));
  return out;
}

Vector3d circle(double t) { return {25.0 * std::cos(t), 25.0 * std::sin(t), 0.0}; }
Vector3d helix(double t) { return {10.0 * std::cos(t), 10.0 * std::sin(t), 1.5 * t}; }
/// A 5-axis-like tool path: a wavy zig along X with swept Y and Z, mm.
Vector3d wavy(double t) {
  return {t, 8.0 * std::sin(t / 9.0) + 1.5 * std::sin(t / 2.3), 3.0 * std::cos(t / 5.0) + 0.4 * std::sin(t / 1.7)};
}

void expect_fit(const ct::FitResult& f, std::size_t n, double tol) {
  EXPECT_TRUE(f.within_tolerance);
  EXPECT_LE(f.max_residual_mm, tol);
  EXPECT_LE(f.rms_residual_mm, f.max_residual_mm);
  ASSERT_EQ(f.params.size(), n);
  EXPECT_EQ(f.params.front(), 0.0);
  EXPECT_EQ(f.params.back(), 1.0);
  for (std::size_t i = 1; i < n; ++i) ASSERT_GT(f.params[i], f.params[i - 1]) << "at " << i;
}

/// Global foot point by dense sampling, then golden-section refinement around the best sample.
double brute_distance(const ct::CubicCurve& c, const Vector3d& q, double* u_out = nullptr) {
  const int n = 20000;
  double best = 1e300, ub = 0.0;
  for (int i = 0; i <= n; ++i) {
    const double u = static_cast<double>(i) / n;
    const double d = (c.point(u) - q).norm();
    if (d < best) best = d, ub = u;
  }
  double a = std::max(0.0, ub - 1.0 / n), b = std::min(1.0, ub + 1.0 / n);
  const double g = (std::sqrt(5.0) - 1.0) / 2.0;
  for (int it = 0; it < 200 && b - a > 1e-16; ++it) {
    const double x1 = b - g * (b - a), x2 = a + g * (b - a);
    if ((c.point(x1) - q).norm() < (c.point(x2) - q).norm()) b = x2;
    else a = x1;
  }
  const double u = 0.5 * (a + b);
  if (u_out) *u_out = u;
  return std::min(best, (c.point(u) - q).norm());
}

/// A unit normal of the curve at u (perpendicular to C').
Vector3d normal_at(const ct::CubicCurve& c, double u, std::mt19937& rng) {
  const Vector3d t = c.evaluate(u).first.normalized();
  std::normal_distribution<double> g;
  Vector3d r(g(rng), g(rng), g(rng));
  return (r - r.dot(t) * t).normalized();
}

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

TEST(CubicCurve, EvaluatesAPolynomialOnAnyKnotVectorWithDerivatives) {
  // Control points by blossoming C(t) = a + b t + c t² + d t³: P_i = f(U_{i+1}, U_{i+2}, U_{i+3}).
  const Vector3d a(1, -2, 3), b(4, 0.5, -1), c(-2, 3, 0.25), d(0.5, -1.5, 2);
  auto blossom = [&](double x, double y, double z) {
    return Vector3d(a + b * (x + y + z) / 3.0 + c * (x * y + y * z + z * x) / 3.0 + d * x * y * z);
  };
  const std::vector<double> U{-1, -1, -1, -1, -0.3, 0.2, 0.2, 0.9, 1.7, 2, 2, 2, 2};
  std::vector<Vector3d> P;
  for (std::size_t i = 0; i + 4 < U.size(); ++i) P.push_back(blossom(U[i + 1], U[i + 2], U[i + 3]));
  const ct::CubicCurve curve(U, P);
  EXPECT_EQ(curve.size(), 9U);
  EXPECT_EQ(curve.domain().begin, -1.0);
  EXPECT_EQ(curve.domain().end, 2.0);
  for (int i = 0; i <= 300; ++i) {
    const double t = -1.0 + 3.0 * i / 300.0;
    const auto D = curve.evaluate(t);
    EXPECT_LT((D.point - (a + b * t + c * t * t + d * t * t * t)).norm(), 1e-12) << t;
    EXPECT_LT((D.first - (b + 2 * c * t + 3 * d * t * t)).norm(), 1e-12) << t;
    EXPECT_LT((D.second - (2 * c + 6 * d * t)).norm(), 1e-11) << t;
    EXPECT_LT((curve.point(t) - D.point).norm(), 1e-13);
  }
}

TEST(CubicCurve, RejectsBadDefinitions) {
  const std::vector<Vector3d> P(5, Vector3d::Zero());
  EXPECT_THROW(ct::CubicCurve({0, 0, 0, 0, 1, 1, 1, 1}, P), postproc::Error);             // count
  EXPECT_THROW(ct::CubicCurve({0, 0, 0, 0.1, 0.5, 1, 1, 1, 1}, P), postproc::Error);      // not clamped
  EXPECT_THROW(ct::CubicCurve({0, 0, 0, 0, 0.5, 0.4, 1, 1, 1}, P), postproc::Error);      // decreasing
  EXPECT_THROW(ct::CubicCurve({0, 0, 0, 0, 1, 1, 1}, {P.begin(), P.begin() + 3}), postproc::Error);
  EXPECT_THROW((void)ct::fit_cubic({}), postproc::Error);
  const std::vector<Vector3d> bad{Vector3d::Zero(), Vector3d(NAN, 0, 0)};
  EXPECT_THROW((void)ct::fit_cubic(bad), postproc::Error);
}

TEST(FitCubic, ReproducesACubicPolynomialCurveExactly) {
  // Sample C(t) at t_i with t_i − t_{i−1} = k·√|C(t_i) − C(t_{i−1})|, so the centripetal
  // parameters are exactly t_i / t_m and C is a cubic polynomial in u: the fit must be exact.
  auto C = [](double t) { return Vector3d(10 * t, 4 * t * t - 3 * t, 2 * t * t * t - t * t + 5); };
  const double k = 0.05;
  std::vector<double> t{0.0};
  while (t.back() < 1.5) {
    double lo = 1e-12, hi = 1.0;
    for (int it = 0; it < 200; ++it) {
      const double h = 0.5 * (lo + hi);
      (h - k * std::sqrt((C(t.back() + h) - C(t.back())).norm()) < 0 ? lo : hi) = h;
    }
    t.push_back(t.back() + 0.5 * (lo + hi));
  }
  std::vector<Vector3d> pts;
  for (double ti : t) pts.push_back(C(ti));
  const auto f = ct::fit_cubic(pts);
  expect_fit(f, pts.size(), 1e-4);
  EXPECT_LT(f.max_residual_mm, 1e-11) << pts.size() << " points";
  EXPECT_EQ(f.rounds, 1);
  EXPECT_LT(f.control_points, pts.size());
  for (std::size_t i = 0; i < t.size(); ++i) EXPECT_NEAR(f.params[i], t[i] / t.back(), 1e-14);
  std::printf("[ cubic    ] %zu points, %zu control points, max residual %.2e mm\n", pts.size(), f.control_points,
              f.max_residual_mm);
}

TEST(FitCubic, CircleHelixAndWavyPathWithinTolerance) {
  struct Case {
    const char* name;
    Curve c;
    double t1;
    std::size_t n;
  };
  for (const Case& k : {Case{"circle", circle, 2 * std::numbers::pi, 720}, Case{"helix", helix, 6 * std::numbers::pi, 3000},
                        Case{"wavy", wavy, 200.0, 4000}}) {
    const auto pts = sample(k.c, 0.0, k.t1, k.n);
    const auto f = ct::fit_cubic(pts);
    SCOPED_TRACE(k.name);
    expect_fit(f, pts.size(), 1e-4);
    std::printf("[ %-8s ] %zu points, %zu control points, %d rounds, max %.2e mm, rms %.2e mm\n", k.name, pts.size(),
                f.control_points, f.rounds, f.max_residual_mm, f.rms_residual_mm);
  }
}

TEST(FitCubic, AddsControlPointsUntilTheToleranceAndReportsACap) {
  const auto pts = sample(wavy, 0.0, 100.0, 400);  // 0.25 mm steps on radii of a few mm
  ct::FitOptions o;
  o.tolerance_mm = 1e-7;
  const auto f = ct::fit_cubic(pts, o);
  expect_fit(f, pts.size(), 1e-7);
  EXPECT_GT(f.rounds, 1);
  o.max_control_points = 20;
  const auto capped = ct::fit_cubic(pts, o);
  EXPECT_EQ(capped.control_points, 20U);
  EXPECT_FALSE(capped.within_tolerance);
  EXPECT_GT(capped.max_residual_mm, 1e-7);
  std::printf("[ grow     ] %zu points at 1e-7 mm: %zu control points in %d rounds, max %.2e mm\n", pts.size(),
              f.control_points, f.rounds, f.max_residual_mm);
}

TEST(FitCubic, DuplicatePointsShareAParameter) {
  auto pts = sample(wavy, 0.0, 50.0, 500);
  std::vector<Vector3d> dup;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    dup.push_back(pts[i]);
    if (i % 7 == 0) dup.push_back(pts[i]), dup.push_back(pts[i] + Vector3d(1e-12, 0, 0));
  }
  dup.push_back(dup.back());
  const auto f = ct::fit_cubic(dup);
  EXPECT_TRUE(f.within_tolerance);
  EXPECT_LE(f.max_residual_mm, 1e-4);
  for (std::size_t i = 1; i < dup.size(); ++i) {
    if ((dup[i] - dup[i - 1]).norm() < 1e-9) EXPECT_EQ(f.params[i], f.params[i - 1]) << i;
    else EXPECT_GT(f.params[i], f.params[i - 1]) << i;
  }
  // Degenerate inputs: one point repeated, two and three distinct points.
  const std::vector<Vector3d> same(5, Vector3d(1, 2, 3));
  const auto f1 = ct::fit_cubic(same);
  EXPECT_EQ(f1.max_residual_mm, 0.0);
  EXPECT_LT((f1.curve.point(0.5) - same[0]).norm(), 1e-15);
  const std::vector<Vector3d> two{Vector3d(0, 0, 0), Vector3d(0, 0, 0), Vector3d(3, 4, 0)};
  const auto f2 = ct::fit_cubic(two);
  EXPECT_LT(f2.max_residual_mm, 1e-14);
  EXPECT_LT((f2.curve.point(0.4) - Vector3d(1.2, 1.6, 0)).norm(), 1e-14);  // exact line, u ∝ length
  const std::vector<Vector3d> three{Vector3d(0, 0, 0), Vector3d(1, 2, 0), Vector3d(4, 0, 1)};
  const auto f3 = ct::fit_cubic(three);
  EXPECT_LT(f3.max_residual_mm, 1e-14);
  EXPECT_GT(f3.params[1], 0.0);
  EXPECT_LT(f3.params[1], 1.0);
}

TEST(Project, AgreesWithBruteForceSampling) {
  const auto pts = sample(wavy, 0.0, 60.0, 1200);
  const auto f = ct::fit_cubic(pts);
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> uu(0.0, 1.0), off(0.0, 0.5), shift(-0.003, 0.003);
  for (int i = 0; i < 200; ++i) {
    const double us = uu(rng);
    const Vector3d q = f.curve.point(us) + off(rng) * normal_at(f.curve, us, rng);
    const auto r = ct::project(f.curve, q, us + shift(rng));
    double ub = 0.0;
    const double d = brute_distance(f.curve, q, &ub);
    EXPECT_TRUE(r.converged) << i;
    EXPECT_NEAR(r.distance, d, 1e-9) << i;
    EXPECT_NEAR(r.distance, (r.point - q).norm(), 1e-15);
    EXPECT_NEAR(r.u, ub, 1e-6) << i;
  }
}

TEST(Project, BackEstimationConvergesInFewStepsAtSmallOffsets) {
  const auto f = ct::fit_cubic(sample(helix, 0.0, 4 * std::numbers::pi, 2000));
  std::mt19937 rng(40);
  std::uniform_real_distribution<double> uu(0.02, 0.98), off(0.0, 0.1), shift(-0.002, 0.002);
  int worst = 0;
  for (int i = 0; i < 500; ++i) {
    const double us = uu(rng);
    const Vector3d q = f.curve.point(us) + off(rng) * normal_at(f.curve, us, rng);
    const auto r = ct::project(f.curve, q, us + shift(rng));  // a start up to ~0.6 mm off along the path
    ASSERT_TRUE(r.converged);
    EXPECT_EQ(r.method, ct::ProjectMethod::back_estimation) << i;
    EXPECT_NEAR(r.distance, brute_distance(f.curve, q), 1e-9) << i;
    worst = std::max(worst, r.iterations);
  }
  EXPECT_LE(worst, 8);
  std::printf("[ back-est ] at most %d steps for normal offsets ≤ 0.1 mm\n", worst);
}

TEST(Project, NewtonTakesOverWhenBackEstimationDiverges) {
  // On the convex side at a distance d > ρ (radius of curvature) the back-estimation step
  // overshoots by the factor d·κ > 1: circle ρ = 5 mm, query 10 mm outside.
  const auto f = ct::fit_cubic(sample([](double t) { return Vector3d(5 * std::cos(t), 5 * std::sin(t), 0); }, 0.0,
                                      std::numbers::pi, 400));
  const Vector3d q(15 * std::cos(1.3), 15 * std::sin(1.3), 0.0);
  const auto r = ct::project(f.curve, q, f.params[120]);
  EXPECT_TRUE(r.converged);
  EXPECT_EQ(r.method, ct::ProjectMethod::newton);
  EXPECT_NEAR(r.distance, brute_distance(f.curve, q), 1e-9);
  EXPECT_NEAR(r.distance, 10.0, 1e-4);
  EXPECT_LT((r.point - Vector3d(5 * std::cos(1.3), 5 * std::sin(1.3), 0)).norm(), 1e-4);
}

TEST(Project, GlobalGuardsFindTheFarMinimum) {
  // A U-shaped path: from a start on the wrong leg, the local answer is a far local minimum.
  std::vector<Vector3d> pts;
  for (int i = 0; i <= 100; ++i) pts.emplace_back(0.0, 50.0 - 0.5 * i, 0.0);
  for (int i = 1; i <= 60; ++i) pts.emplace_back(5.0 - 5.0 * std::cos(i * std::numbers::pi / 60), -5.0 * std::sin(i * std::numbers::pi / 60), 0.0);
  for (int i = 1; i <= 100; ++i) pts.emplace_back(10.0, 0.5 * i, 0.0);
  const auto f = ct::fit_cubic(pts);
  const Vector3d q(9.0, 30.0, 0.0);  // 1 mm from the right leg, 9 mm from the left one
  const auto local = ct::project(f.curve, q, f.params[40]);
  EXPECT_NEAR(local.distance, 9.0, 1e-3);
  ct::ProjectOptions o;
  o.samples_per_span = 4;
  const auto global = ct::project(f.curve, q, f.params[40], o);
  EXPECT_EQ(global.method, ct::ProjectMethod::global);
  EXPECT_NEAR(global.distance, 1.0, 1e-3);
  EXPECT_NEAR(global.distance, brute_distance(f.curve, q), 1e-9);
}

TEST(FitWindows, HundredThousandPointsMatchTheSingleFit) {
  const std::size_t n = 100000;
  const auto pts = sample(wavy, 0.0, 2000.0, n);  // 0.02 mm steps
  auto t0 = std::chrono::steady_clock::now();
  const auto single = ct::fit_cubic(pts);
  const double t_single = seconds_since(t0);
  t0 = std::chrono::steady_clock::now();
  const std::size_t window = 2000, overlap = 200;
  const auto w = ct::fit_windows(pts, window, overlap);
  const double t_windows = seconds_since(t0);
  expect_fit(single, n, 1e-4);
  EXPECT_TRUE(w.within_tolerance());
  EXPECT_LE(w.max_residual_mm(), 1e-4);
  ASSERT_FALSE(w.pieces.empty());
  EXPECT_EQ(w.pieces.front().begin, 0U);
  EXPECT_EQ(w.pieces.back().end, n);
  for (std::size_t k = 0; k < w.pieces.size(); ++k) {
    EXPECT_EQ(w.pieces[k].end - w.pieces[k].begin, window);
    if (k > 0) {
      EXPECT_GE(w.pieces[k - 1].end, w.pieces[k].begin + overlap);
    }
  }
  double worst = 0.0, worst_between = 0.0;
  std::size_t worst_margin = window;
  for (std::size_t i = 0; i < n; ++i) {
    const auto& piece = w.piece_for(i);
    ASSERT_LE(piece.begin, i);
    ASSERT_GT(piece.end, i);
    if (i >= overlap && i + overlap < n) worst_margin = std::min(worst_margin, std::min(i - piece.begin, piece.end - 1 - i));
    const Vector3d a = piece.fit.curve.point(piece.param(i)), b = single.curve.point(single.params[i]);
    worst = std::max(worst, (a - b).norm());
    if (i % 10 == 0 && i + 1 < piece.end) {  // between samples: the curves agree too
      const Vector3d mid = piece.fit.curve.point(0.5 * (piece.param(i) + piece.param(i + 1)));
      const auto r = ct::project(single.curve, mid, 0.5 * (single.params[i] + single.params[i + 1]));
      worst_between = std::max(worst_between, r.distance);
    }
  }
  EXPECT_LE(worst, 2e-4);
  EXPECT_LE(worst_between, 2e-4);
  EXPECT_GE(worst_margin, overlap / 2 - 1);
  EXPECT_THROW((void)w.piece_for(n), postproc::Error);
  EXPECT_THROW((void)ct::fit_windows(pts, 10, 10), postproc::Error);

  // Projection speed: a query near each point, started from its fitted parameter.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> off(-0.05, 0.05);
  t0 = std::chrono::steady_clock::now();
  double sum = 0.0;
  int its = 0;
  for (std::size_t i = 0; i < n; ++i) {
    const auto r = ct::project(single.curve, pts[i] + Vector3d(off(rng), off(rng), off(rng)), single.params[i]);
    sum += r.distance;
    its += r.iterations;
  }
  const double t_proj = seconds_since(t0);
  EXPECT_GT(sum, 0.0);
  std::printf("[ windows  ] %zu pieces of %zu (overlap %zu); pieces vs single: at points %.2e mm, between %.2e mm\n",
              w.pieces.size(), window, overlap, worst, worst_between);
  std::printf("[ timing   ] single fit: %.0f points/s (%zu control points, %d rounds, max %.2e mm); "
              "windowed: %.0f points/s; projection: %.0f queries/s (%.2f steps/query)\n",
              static_cast<double>(n) / t_single, single.control_points, single.rounds, single.max_residual_mm,
              static_cast<double>(n) / t_windows, static_cast<double>(n) / t_proj, static_cast<double>(its) / static_cast<double>(n));
}

}  // namespace
