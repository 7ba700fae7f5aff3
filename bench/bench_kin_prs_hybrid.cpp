// Rates of the 3-PRS hybrid machine's kinematics (document 001 geometry, Table 1 errors): the
// nominal closed-form inverse, the inverse with errors, the forward Newton, and the tool-tip remap
// of parallel machines, command' = FK_nominal(IK_actual(target)).
#include <benchmark/benchmark.h>

#include <cmath>
#include <random>
#include <vector>

#include "postproc/kinematics/prs_hybrid.hpp"

namespace {

using namespace postproc::kin;

/// 1024 targets in the paper's workspace (tip 700–900 mm from the base, θ ≤ 40°, any φ).
const std::vector<Pose>& targets() {
  static const std::vector<Pose> t = [] {
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> z(700, 900), th(0, 40 * kDeg), ph(-kPi, kPi), xy(-300, 300);
    const Eigen::Matrix3d f = Eigen::Vector3d(1, -1, -1).asDiagonal();
    std::vector<Pose> v(1024);
    for (Pose& p : v) {
      const double theta = th(rng), phi = ph(rng);
      p.p = Eigen::Vector3d(xy(rng), xy(rng), -z(rng));
      const Eigen::Vector3d n(std::sin(theta) * std::cos(phi), std::sin(theta) * std::sin(phi), std::cos(theta));
      p.r = f * PrsHybrid::tilt_rotation(n) * f;
    }
    return v;
  }();
  return t;
}

const PrsHybrid& nominal() {
  static const auto m = make_document001_machine();
  return *m;
}
const PrsHybrid& actual() {
  static const auto m = make_document001_machine()->with_errors(document001_table1_errors());
  return *m;
}

void BM_NominalInverseClosedForm(benchmark::State& state) {
  const auto& t = targets();
  std::size_t k = 0;
  JointVector q;
  for (auto _ : state) {
    benchmark::DoNotOptimize(nominal().nominal_inverse(t[k++ & 1023], q));
    benchmark::DoNotOptimize(q);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_NominalInverseClosedForm);

void BM_ActualInverse(benchmark::State& state) {
  const auto& t = targets();
  const JointVector start = JointVector::Zero(5);
  std::size_t k = 0;
  JointVector q;
  for (auto _ : state) {
    benchmark::DoNotOptimize(actual().inverse(t[k++ & 1023], start, q));
    benchmark::DoNotOptimize(q);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_ActualInverse);

void BM_Forward(benchmark::State& state) {
  std::vector<JointVector> qs;
  for (const Pose& p : targets()) {
    JointVector q;
    if (actual().inverse(p, JointVector::Zero(5), q).ok()) qs.push_back(q);
  }
  std::size_t k = 0;
  Pose out;
  for (auto _ : state) {
    benchmark::DoNotOptimize(actual().forward(qs[k++ % qs.size()], out));
    benchmark::DoNotOptimize(out);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Forward);

void BM_Jacobian(benchmark::State& state) {
  JointVector q;
  (void)actual().inverse(targets()[3], JointVector::Zero(5), q);
  for (auto _ : state) benchmark::DoNotOptimize(actual().jacobian(q));
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Jacobian);

/// The compensation of a parallel machine: the joint values the real machine needs for the
/// target, turned back into the pose the (nominal) controller must be commanded.
void BM_Remap(benchmark::State& state) {
  const auto& t = targets();
  const JointVector start = JointVector::Zero(5);
  std::size_t k = 0;
  JointVector q;
  Pose command;
  for (auto _ : state) {
    const Solve ik = actual().inverse(t[k++ & 1023], start, q);
    const Solve fk = nominal().forward(q, command);
    benchmark::DoNotOptimize(ik);
    benchmark::DoNotOptimize(fk);
    benchmark::DoNotOptimize(command);
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_Remap);

}  // namespace

BENCHMARK_MAIN();
