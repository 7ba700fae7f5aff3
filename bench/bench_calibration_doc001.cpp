// Document 001's identification experiment per method: the largest tool-tip error on the
// z = 700 mm plane before and after identification (mm), Ceres LM iterations and solve time.
// A plain main printing a table (the solve is one-shot; timings are the median of 5 runs).
#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <cstdio>
#include <vector>

#include "postproc/calibration/identify.hpp"
#include "postproc/calibration/plan.hpp"
#include "postproc/kinematics/hexapod.hpp"

namespace {
std::string fmt_share(int n, int in1, int in2, int in3) {
  char buf[160];
  std::snprintf(buf, sizeof buf, "%d estimates, within 1σ %.3f, 2σ %.3f, 3σ %.4f of the truth (Gaussian 0.683, 0.954, 0.997)", n,
                static_cast<double>(in1) / n, static_cast<double>(in2) / n, static_cast<double>(in3) / n);
  return buf;
}
}  // namespace

int main() {
  using namespace postproc;
  using cal::Method;
  const auto nominal = kin::make_document001_machine();
  const auto truth = nominal->with_errors(kin::document001_table1_errors());
  const auto poses = cal::doc001::pose_set();
  const double before = cal::doc001::max_tip_error_z700(*nominal, *truth);
  struct Row {
    const char* name;
    Method method;
    bool torsion;
    double lambda;
  };
  const Row rows[] = {
      {"least_squares (6-DoF)", Method::least_squares, true, 0},
      {"least_squares (5-DoF)", Method::least_squares, false, 0},
      {"ridge GCV lambda (5-DoF)", Method::ridge, false, 0},
      {"ridge lambda=1e-3 (5-DoF)", Method::ridge, false, 1e-3},
      {"psi_substitution (5-DoF)", Method::psi_substitution, false, 0},
  };
  std::printf("document 001 experiment: 27 poses, noise ±0.01 mm / ±0.01°, seed 20190331\n");
  std::printf("paper: before 7.2578; after LS 0.0149 (7 it, 0.2 s), ridge 0.0144 (550 it, ~10 min), improved 0.0152 (23 it, 0.8 s)\n\n");
  std::printf("%-26s %10s %10s %6s %10s %10s\n", "method", "before mm", "after mm", "iter", "lambda", "solve s");
  for (const Row& row : rows) {
    const auto data = cal::doc001::simulate(*nominal, *truth, poses, 20190331u, row.torsion);
    cal::IdentifyOptions opt;
    opt.method = row.method;
    opt.ridge_lambda = row.lambda;
    opt.max_iterations = row.method == Method::ridge ? 1000 : 150;
    std::vector<double> times;
    cal::IdentifyResult r;
    for (int k = 0; k < 5; ++k) {
      r = cal::identify(*nominal, data, opt);
      times.push_back(r.seconds);
    }
    std::sort(times.begin(), times.end());
    const double after = cal::doc001::max_tip_error_z700(*std::static_pointer_cast<const kin::PrsHybrid>(nominal->with_values(r.values)), *truth);
    std::printf("%-26s %10.4f %10.5f %6d %10.3g %10.4f\n", row.name, before, after, r.iterations,
                r.lambda, times[2]);
  }

  // Document 003: the hexapod's 42 parameters from strut readings at planned poses.
  {
    const auto design = std::make_shared<kin::Hexapod>(kin::hexapod_design());
    std::vector<double> v = design->values();
    std::mt19937 rng(3);
    std::uniform_real_distribution<double> u(-0.03, 0.03);
    for (double& x : v) x += u(rng);  // ±30 µm on every parameter
    const auto truth_hex = design->with_values(v);
    cal::PlanOptions po;
    po.poses = 36;
    po.kind = cal::MeasurementKind::struts;
    const cal::PlanResult plan = cal::plan_poses(*design, po);
    cal::SimulateOptions so;
    so.kind = cal::MeasurementKind::struts;
    so.noise_mm = 0.0005;
    const auto data = cal::simulate_measurements(*truth_hex, *design, plan.joints, so);
    std::string mc;
    // Are the standard deviations honest? Over 40 noise draws, the share of parameters within
    // 1σ, 2σ, 3σ of the truth (Gaussian: 0.683, 0.954, 0.997).
    {
      int n = 0, in1 = 0, in2 = 0, in3 = 0;
      for (unsigned seed = 1; seed <= 40; ++seed) {
        cal::SimulateOptions s2 = so;
        s2.seed = seed;
        const auto d2 = cal::simulate_measurements(*truth_hex, *design, plan.joints, s2);
        const auto r2 = cal::identify(*design, d2);
        for (int k : r2.identified) {
          const double z = std::abs(r2.values[static_cast<std::size_t>(k)] - v[static_cast<std::size_t>(k)]) / r2.stddev[static_cast<std::size_t>(k)];
          ++n;
          in1 += z <= 1 ? 1 : 0;
          in2 += z <= 2 ? 1 : 0;
          in3 += z <= 3 ? 1 : 0;
        }
      }
      mc = fmt_share(n, in1, in2, in3);
    }
    std::vector<double> times;
    cal::IdentifyResult r;
    for (int k = 0; k < 5; ++k) {
      r = cal::identify(*design, data);
      times.push_back(r.seconds);
    }
    std::sort(times.begin(), times.end());
    int within = 0;
    double worst = 0, worst_abs = 0;
    for (int k : r.identified) {
      const double ratio = std::abs(r.values[static_cast<std::size_t>(k)] - v[static_cast<std::size_t>(k)]) / r.stddev[static_cast<std::size_t>(k)];
      worst = std::max(worst, ratio);
      worst_abs = std::max(worst_abs, std::abs(r.values[static_cast<std::size_t>(k)] - v[static_cast<std::size_t>(k)]));
      within += ratio <= 3 ? 1 : 0;
    }
    std::printf("\nhexapod (document 003): 42 parameters, truth = design ±30 µm, 36 planned poses (planning %.3f s, "
                "condition %.4g), strut noise ±0.5 µm\n",
                plan.seconds, plan.planned.condition);
    std::printf("  identified %zu, within 3σ %d, worst |error|/σ %.2f, worst |error| %.2f µm, residual σ %.5f mm, %d "
                "iterations, solve %.4f s\n",
                r.identified.size(), within, worst, worst_abs * 1000, r.sigma, r.iterations, times[2]);
    std::printf("  over 40 noise draws: %s\n", mc.c_str());
  }
  return 0;
}
