// Document 001's identification experiment per method: the largest tool-tip error on the
// z = 700 mm plane before and after identification (mm), Ceres LM iterations and solve time.
// A plain main printing a table (the solve is one-shot; timings are the median of 5 runs).
#include <algorithm>
#include <cstdio>
#include <vector>

#include "postproc/calibration/identify.hpp"

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
  return 0;
}
