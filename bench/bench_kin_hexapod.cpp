// Hexapod kinematics rates: closed-form IK, Newton FK (from home and seeded with the target) and
// the tool-tip remap of a parallel machine, command' = FK_nominal(IK_actual(target)), over 1024
// random poses of a ±100 mm / ±15° work space; the actual machine has ±50 µm parameter errors.
#include <benchmark/benchmark.h>

#include <random>
#include <vector>

#include "postproc/kinematics/hexapod.hpp"

namespace {

namespace kin = postproc::kin;

struct Fixture {
  std::shared_ptr<const kin::Hexapod> nominal;
  std::shared_ptr<const kin::Model> actual;
  std::vector<kin::Pose> targets;
  std::vector<kin::JointVector> struts;  // IK_actual of the targets
};

const Fixture& fixture() {
  static const Fixture f = [] {
    Fixture x;
    std::mt19937 rng(7);
    std::uniform_real_distribution<double> d(-1, 1);
    x.nominal = std::make_shared<const kin::Hexapod>(kin::hexapod_design());
    std::vector<double> v = x.nominal->values();
    for (double& p : v) p += 0.05 * d(rng);
    x.actual = x.nominal->with_values(v);
    const kin::Pose home = x.nominal->tool_pose({x.nominal->config().home.linear(), x.nominal->config().home.translation()});
    kin::IkOptions full;
    full.match = kin::PoseMatch::full;
    for (int n = 0; n < 1024; ++n) {
      kin::Pose p;
      p.p = home.p + 100 * Eigen::Vector3d(d(rng), d(rng), d(rng));
      p.r = (Eigen::AngleAxisd(15 * kin::kDeg * d(rng), Eigen::Vector3d::UnitX()) *
             Eigen::AngleAxisd(15 * kin::kDeg * d(rng), Eigen::Vector3d::UnitY()) *
             Eigen::AngleAxisd(15 * kin::kDeg * d(rng), Eigen::Vector3d::UnitZ()))
                .toRotationMatrix();
      kin::JointVector q;
      if (!x.actual->inverse(p, kin::JointVector::Zero(6), q, full).ok()) continue;
      x.targets.push_back(p);
      x.struts.push_back(q);
    }
    return x;
  }();
  return f;
}

kin::IkOptions full_match() {
  kin::IkOptions o;
  o.match = kin::PoseMatch::full;
  return o;
}

void BM_HexapodInverse(benchmark::State& state) {
  const Fixture& f = fixture();
  const kin::IkOptions opt = full_match();
  const kin::JointVector start = kin::JointVector::Zero(6);
  std::size_t i = 0;
  kin::JointVector q;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.actual->inverse(f.targets[i], start, q, opt));
    benchmark::DoNotOptimize(q.data());
    if (++i == f.targets.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_HexapodInverse);

void BM_HexapodForwardFromHome(benchmark::State& state) {
  const Fixture& f = fixture();
  std::size_t i = 0;
  kin::Pose out;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.nominal->forward(f.struts[i], out));
    benchmark::DoNotOptimize(out.p.data());
    if (++i == f.struts.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_HexapodForwardFromHome);

void BM_HexapodForwardSeeded(benchmark::State& state) {
  const Fixture& f = fixture();
  std::size_t i = 0;
  kin::Pose out;
  for (auto _ : state) {
    benchmark::DoNotOptimize(f.nominal->forward(f.struts[i], out, f.targets[i]));
    benchmark::DoNotOptimize(out.p.data());
    if (++i == f.struts.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
}
BENCHMARK(BM_HexapodForwardSeeded);

// The remap of one block: the struts the actual machine needs for the target, then the pose the
// nominal NC must be commanded so its own IK produces those struts (FK seeded with the target).
void BM_HexapodRemap(benchmark::State& state) {
  const Fixture& f = fixture();
  const kin::IkOptions opt = full_match();
  const kin::JointVector start = kin::JointVector::Zero(6);
  std::size_t i = 0;
  kin::JointVector q;
  kin::Pose command;
  std::int64_t failed = 0;
  for (auto _ : state) {
    const kin::Pose& target = f.targets[i];
    if (!f.actual->inverse(target, start, q, opt).ok() || !f.nominal->forward(q, command, target).ok()) ++failed;
    benchmark::DoNotOptimize(command.p.data());
    if (++i == f.targets.size()) i = 0;
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["failed"] = static_cast<double>(failed);
}
BENCHMARK(BM_HexapodRemap);

}  // namespace

BENCHMARK_MAIN();
