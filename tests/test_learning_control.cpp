// The normal equations of the refinement on the simulation (contour/learning_control.hpp): fed
// samples whose contour errors a known end-point shift would cancel exactly, the block-tridiagonal
// solve returns that shift (plus the drives' lag of it), and leaves the points it may not move.
#include <gtest/gtest.h>

#include <cstdio>

#include "contour_support.hpp"
#include "postproc/contour/learning_control.hpp"
#include "postproc/contour/precompensate.hpp"
#include "postproc/contour/reference.hpp"
#include "postproc/contour/simulate.hpp"

namespace {

namespace ct = postproc::contour;
namespace kin = postproc::kin;

/// The contour error that a joint shift `dq` at joints `q` would cancel: the pose change J·dq.
ct::ContourError error_of_shift(const kin::Model& model, const kin::JointVector& q, const kin::JointVector& dq) {
  const kin::Jacobian j = model.jacobian(q);
  ct::ContourError e;
  e.vector = j.topRows<3>() * dq;
  e.rotation = j.bottomRows<3>() * dq;
  e.distance = e.vector.norm();
  e.angle = e.rotation.norm();
  e.axis = Eigen::Vector3d::UnitZ();
  return e;
}

/// Feeds `eq` the samples of every segment of run 0 at ten fractions each, with the contour error
/// that the end-point shifts `x` (per path point; zero where the point is not correctable) would
/// cancel under the learning model: the actual joints move by (1 − f)·x_a + f·x_b.
void feed(ct::SampleEquations& eq, const ct::Path& p, const kin::Model& model, const std::vector<kin::JointVector>& x) {
  const ct::Run& run = p.runs[0];
  for (std::size_t s = run.begin + 1; s < run.end; ++s)
    for (int k = 0; k < 10; ++k) {
      const double f = 0.05 + 0.1 * k;
      const kin::JointVector q = p.points[s - 1].q + f * (p.points[s].q - p.points[s - 1].q);
      const ct::ContourError e = error_of_shift(model, q, (1 - f) * x[s - 1] + f * x[s]);
      eq.add(ct::SampleVisit{0, s, f, q, model, e});
    }
}

/// The step solved from exact samples of the shifts x, undamped and unsmoothed, with the run's
/// rows weighted (tool tip, tool axis).
std::vector<kin::JointVector> exact_step(const ct::Path& p, const kin::Model& model, const std::vector<kin::JointVector>& x,
                                         double weight_tip = 1, double weight_axis = 1) {
  ct::SampleEquations eq(p, 100);
  eq.weigh(0, weight_tip, weight_axis);
  feed(eq, p, model, x);
  ct::LearningOptions opt;
  opt.damping = 0;
  opt.smoothing = 0;
  std::vector<kin::JointVector> step(p.points.size(), kin::JointVector::Zero(3));
  eq.solve(p.runs[0], opt, step);
  return step;
}

ct::Path circle_path() {
  ct::Path p = pptest::empty_path(pptest::mill());
  pptest::add_run(p, pptest::circle(Eigen::Vector3d(0, 0, -5), 20, 24), 30);
  return p;
}

TEST(LearningControl, RecoversAConstantShift) {
  const ct::Path p = circle_path();
  const kin::Model& model = *pptest::mill().actual;
  const kin::JointVector shift = pptest::xyz(0.003, -0.002, 0.001);
  std::vector<kin::JointVector> x(p.points.size(), kin::JointVector::Zero(3));
  for (std::size_t i = 0; i < p.points.size(); ++i)
    if (ct::correctable(p, p.runs[0], i)) x[i] = shift;
  const std::vector<kin::JointVector> step = exact_step(p, model, x);
  // A constant shift has no rate, so no lag term: the step is the shift itself.
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    SCOPED_TRACE(i);
    EXPECT_LT((step[i] - x[i]).norm(), 1e-9);
  }
  // The run's first and last points are not moved (the machine is at rest on them).
  EXPECT_EQ(step.front().norm(), 0.0);
  EXPECT_EQ(step.back().norm(), 0.0);
}

TEST(LearningControl, AddsTheDrivesLagOfAShiftThatVariesAlongTheRun) {
  const ct::Path p = circle_path();
  const kin::Model& model = *pptest::mill().actual;
  // x(t) = a + b·t on the correctable points: the commands take x + e₁·ẋ = x + e₁·b, exact for a
  // linear x with central (and at the ends one-sided) differences.
  const kin::JointVector a = pptest::xyz(0.001, 0.002, -0.001), b = pptest::xyz(0.004, -0.003, 0.002);
  std::vector<kin::JointVector> x(p.points.size(), kin::JointVector::Zero(3));
  for (std::size_t i = 0; i < p.points.size(); ++i)
    if (ct::correctable(p, p.runs[0], i)) x[i] = a + p.points[i].t * b;
  // Weights scale the rows: a consistent system has the same solution under any weights.
  const std::vector<kin::JointVector> step = exact_step(p, model, x, 7.5, 0.25);
  int checked = 0;
  for (std::size_t i = 0; i < p.points.size(); ++i) {
    if (!ct::correctable(p, p.runs[0], i)) {
      EXPECT_EQ(step[i].norm(), 0.0) << i;
      continue;
    }
    kin::JointVector want = x[i];
    for (int j = 0; j < 3; ++j) want[j] += p.drives[static_cast<std::size_t>(j)].lag(b[j]);
    EXPECT_LT((step[i] - want).norm(), 1e-8) << i;
    ++checked;
  }
  EXPECT_EQ(checked, 23);
}

TEST(LearningControl, NoSamplesNoStep) {
  const ct::Path p = circle_path();
  ct::SampleEquations eq(p, 100);
  std::vector<kin::JointVector> step(p.points.size(), kin::JointVector::Zero(3));
  eq.solve(p.runs[0], ct::LearningOptions{}, step);
  for (const auto& s : step) EXPECT_EQ(s.norm(), 0.0);
  // Samples gathered and then cleared leave nothing either.
  std::vector<kin::JointVector> x(p.points.size(), pptest::xyz(0.01, 0, 0));
  feed(eq, p, *pptest::mill().actual, x);
  eq.clear();
  eq.solve(p.runs[0], ct::LearningOptions{}, step);
  for (const auto& s : step) EXPECT_EQ(s.norm(), 0.0);
}

/// The dynamic model (LearningOptions::dynamic) against the time-domain simulator itself: the
/// actual joints of a path whose points are shifted by x differ from those of the path as it is
/// by Σ_k ψ_k(t)·x_k, the drives' responses to the shifts' hat functions. Fed that difference as
/// the error to cancel, the solve returns x. A square corner (X then Y, 0.5 mm points at F2000,
/// Kv 30/s: the shifts vary faster than the drives follow) and shifts in Z, normal to every move,
/// so the timing stays the same.
TEST(LearningControl, DynamicModelMatchesTheSimulatedDrives) {
  const kin::Model& model = *pptest::mill().actual;
  std::vector<kin::JointVector> pts, shifted;
  for (int k = 0; k <= 20; ++k) pts.push_back(pptest::xyz(0.5 * k, 0, 0));
  for (int k = 1; k <= 20; ++k) pts.push_back(pptest::xyz(10, 0.5 * k, 0));
  ct::Path p = pptest::empty_path(pptest::mill());
  pptest::add_run(p, pts, 2000.0 / 60);
  std::vector<kin::JointVector> x(pts.size(), kin::JointVector::Zero(3));
  for (std::size_t k = 0; k < pts.size(); ++k) {
    if (ct::correctable(p, p.runs[0], k)) x[k] = pptest::xyz(0, 0, 0.002 * std::sin(0.7 * static_cast<double>(k)));
    shifted.push_back(pts[k] + x[k]);
  }
  ct::Path q = p;  // the same timing
  for (std::size_t k = 0; k < pts.size(); ++k) q.points[k].q = shifted[k];
  const ct::Reference ref(p, model);
  struct Seen {
    std::size_t run, segment;
    double fraction, t;
    kin::JointVector actual;
  };
  const auto run_sim = [&](const ct::Path& path) {
    std::vector<Seen> seen;
    ct::SimulateOptions so;
    so.visit = [&](const ct::SampleVisit& v) { seen.push_back(Seen{v.run, v.segment, v.fraction, v.t, v.actual}); };
    (void)ct::simulate(path, ref, model, so);
    return seen;
  };
  const std::vector<Seen> a = run_sim(p), b = run_sim(q);
  ASSERT_EQ(a.size(), b.size());
  ASSERT_GT(a.size(), 500u);
  const auto solve = [&](bool dynamic) {
    ct::SampleEquations eq(p, 100, dynamic);
    for (std::size_t i = 0; i < a.size(); ++i) {
      const ct::ContourError e = error_of_shift(model, a[i].actual, b[i].actual - a[i].actual);
      eq.add(ct::SampleVisit{a[i].run, a[i].segment, a[i].fraction, a[i].actual, model, e, a[i].t, &p});
    }
    ct::LearningOptions opt;
    opt.damping = 1e-9;
    opt.smoothing = 0;
    std::vector<kin::JointVector> step(p.points.size(), kin::JointVector::Zero(3));
    eq.solve(p.runs[0], opt, step);
    double worst = 0;
    for (std::size_t k = 0; k < pts.size(); ++k) worst = std::max(worst, (step[k] - x[k]).norm());
    return worst;
  };
  const double dynamic = solve(true), quasi_static = solve(false);
  std::printf("recovered shift: dynamic %.3g mm, quasi-static %.3g mm off\n", dynamic, quasi_static);
  EXPECT_LT(dynamic, 0.05 * 0.002) << "dynamic model: largest error of the recovered shift, mm";
  // The quasi-static model cannot follow shifts this fast: it recovers them far worse.
  EXPECT_GT(quasi_static, 5 * dynamic);
}

}  // namespace
