// Serial-chain kinematics rates: forward kinematics (nominal and with every error and table),
// the analytic Jacobian, and the compensation remap q' = IK_actual(FK_nominal(q), start = q) of an
// A/C trunnion, a C/B fork head and the X Z B C lathe. Each case reports items_per_second; the
// remaps also count the blocks whose solve was not ok ("failed", expected 0). BM_Remap/<machine>/1
// uses the tolerances compensation uses (ProgramMap::correct: 1e-9 mm, 1e-11 rad), /0 the IkOptions
// defaults (1e-10 mm, 1e-12 rad).
#include <benchmark/benchmark.h>

#include <cmath>
#include <limits>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "postproc/kinematics/serial.hpp"

namespace {

using namespace postproc::kin;
using Eigen::Vector3d;
constexpr int kSamples = 4096;

SerialAxis axis(const std::string& name, JointType type, Vector3d dir, Vector3d pivot, double lo, double hi) {
  SerialAxis a;
  a.name = name;
  a.type = type;
  a.direction = dir;
  a.pivot = pivot;
  a.min = lo;
  a.max = hi;
  return a;
}

SerialAxis lin(const std::string& n, Vector3d d, double lo, double hi) {
  return axis(n, JointType::linear, d, Vector3d::Zero(), lo, hi);
}
SerialAxis rot(const std::string& n, Vector3d d, Vector3d p, double lo, double hi) {
  return axis(n, JointType::rotary, d, p, lo, hi);
}

std::vector<SerialAxis> xyz() {
  return {lin("X", Vector3d::UnitX(), -500, 500), lin("Y", Vector3d::UnitY(), -400, 400),
          lin("Z", Vector3d::UnitZ(), -400, 100)};
}

// Which machine, and the rotary joint kept ≥ 5° from its singular angle when sampling.
struct Machine {
  SerialConfig cfg;
  int tilt;
  double singular;
};

Machine table_ac() {
  Machine m{{}, 0, 0};
  m.cfg.workpiece_side = {rot("A", Vector3d::UnitX(), Vector3d(0, 0, -50), -110, 30),
                          rot("C", Vector3d::UnitZ(), Vector3d(0, 0, 0), -360, 360)};
  m.cfg.tool_side = xyz();
  m.cfg.spindle_point = Vector3d(0, 0, 250);
  m.cfg.tool_length = 120;
  return m;
}

Machine head_head() {
  Machine m{{}, 4, 0};
  m.cfg.tool_side = xyz();
  m.cfg.tool_side.push_back(rot("C", Vector3d::UnitZ(), Vector3d::Zero(), -360, 360));
  m.cfg.tool_side.push_back(rot("B", Vector3d::UnitY(), Vector3d(0, 0, 150), -100, 100));
  m.cfg.spindle_point = Vector3d(0, 0, 100);
  m.cfg.tool_length = 80;
  return m;
}

// Document 004: bed → X → C → workpiece, bed → Z → B → tool; the tool lies along +X at B = 0.
Machine lathe() {
  Machine m{{}, 3, 90};
  m.cfg.workpiece_side = {lin("X", -Vector3d::UnitX(), -50, 300), rot("C", Vector3d::UnitZ(), Vector3d::Zero(), -360, 360)};
  m.cfg.tool_side = {lin("Z", Vector3d::UnitZ(), -500, 50), rot("B", Vector3d::UnitY(), Vector3d(200, 0, 0), -80, 80)};
  m.cfg.spindle_point = Vector3d(150, 0, 0);
  m.cfg.tool_axis = Vector3d::UnitX();
  m.cfg.tool_x = Vector3d::UnitZ();
  m.cfg.tool_length = 50;
  return m;
}

// The nominal model, the actual one (every ISO error: ±50 µm, ±50"; 21-row error-motion tables on
// every axis: ±20 µm, ±20") and joint samples within travel.
struct Setup {
  std::shared_ptr<const Model> nominal;
  std::shared_ptr<const Model> actual;
  std::vector<JointVector> q;
};

Setup make(const Machine& mc) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  SerialConfig c = mc.cfg;
  for (auto* side : {&c.workpiece_side, &c.tool_side})
    for (auto& a : *side)
      for (int r = 0; r <= 20; ++r) {
        a.table.position.push_back(a.min + (a.max - a.min) * r / 20.0);
        a.table.error.push_back({0.02 * u(rng), 0.02 * u(rng), 0.02 * u(rng), 1e-4 * u(rng), 1e-4 * u(rng),
                                 1e-4 * u(rng)});
      }
  Setup s;
  s.nominal = std::make_shared<const SerialModel>(mc.cfg);
  const SerialModel base(c);
  std::vector<double> v;
  for (const auto& p : base.parameters()) v.push_back(!p.error ? p.nominal : u(rng) * (p.unit == "mm" ? 0.05 : 2.5e-4));
  s.actual = base.with_values(v);
  for (int i = 0; i < kSamples; ++i) {
    JointVector q(s.actual->joint_count());
    for (int j = 0; j < q.size(); ++j) {
      const Joint& jt = s.actual->joints()[static_cast<std::size_t>(j)];
      std::uniform_real_distribution<double> in(jt.min, jt.max);
      do q[j] = in(rng);
      while (j == mc.tilt && std::abs(q[j] - mc.singular) < 5);
    }
    s.q.push_back(q);
  }
  return s;
}

const Setup& setup(int which) {
  static const Setup s[3] = {make(table_ac()), make(head_head()), make(lathe())};
  return s[which];
}

void BM_ForwardNominal(benchmark::State& state) {
  const Setup& s = setup(0);
  std::size_t i = 0;
  Pose p;
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.nominal->forward(s.q[i++ % kSamples], p));
    benchmark::DoNotOptimize(p);
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_ForwardActual(benchmark::State& state) {
  const Setup& s = setup(0);
  std::size_t i = 0;
  Pose p;
  for (auto _ : state) {
    benchmark::DoNotOptimize(s.actual->forward(s.q[i++ % kSamples], p));
    benchmark::DoNotOptimize(p);
  }
  state.SetItemsProcessed(state.iterations());
}

void BM_JacobianActual(benchmark::State& state) {
  const Setup& s = setup(0);
  std::size_t i = 0;
  for (auto _ : state) benchmark::DoNotOptimize(s.actual->jacobian(s.q[i++ % kSamples]));
  state.SetItemsProcessed(state.iterations());
}

// One compensated block: the pose the program meant, solved on the actual machine from q.
void BM_Remap(benchmark::State& state) {
  const Setup& s = setup(static_cast<int>(state.range(0)));
  std::size_t i = 0;
  double failed = 0;
  double iterations = 0;
  IkOptions opt;
  opt.check_limits = false;
  const bool compensation = state.range(1) != 0;
  if (compensation) {
    opt.tolerance_mm = 1e-9;
    opt.tolerance_rad = 1e-11;
  }
  Pose p;
  JointVector out;
  for (auto _ : state) {
    const JointVector& q = s.q[i++ % kSamples];
    (void)forward(*s.nominal, q, p);
    const Solve r = inverse(*s.actual, p, q, out, opt);
    if (!r.ok()) ++failed;
    iterations += r.iterations;
    benchmark::DoNotOptimize(out);
  }
  state.SetItemsProcessed(state.iterations());
  state.counters["failed"] = failed;
  state.counters["iterations"] = benchmark::Counter(iterations, benchmark::Counter::kAvgIterations);
  state.SetLabel(std::string(state.range(0) == 0 ? "table-table AC" : state.range(0) == 1 ? "head-head CB" : "lathe XZBC") +
                (compensation ? ", compensation tolerances" : ", default tolerances"));
}

BENCHMARK(BM_ForwardNominal);
BENCHMARK(BM_ForwardActual);
BENCHMARK(BM_JacobianActual);
BENCHMARK(BM_Remap)->ArgsProduct({{0, 1, 2}, {1, 0}});

}  // namespace

BENCHMARK_MAIN();
