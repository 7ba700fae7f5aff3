// Document 001's identification experiment (section 3): the 3-PRS hybrid machine with Table 1
// errors, 27 measured poses on z = 700/800/900 mm with ±0.01 mm / ±0.01° noise, the 33 errors
// identified from the nominal model by least squares (6-DoF data), ridge and ψ substitution
// (5-DoF data); the tool-tip error on the z = 700 mm plane before and after.
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "postproc/calibration/identify.hpp"
#include "postproc/error.hpp"

namespace {

using namespace postproc;
using namespace postproc::kin;
using cal::Method;

constexpr unsigned kSeed = 20190331;
constexpr double kPaperBest = 0.0149;  // document 001, least squares after identification, mm

struct Experiment {
  std::shared_ptr<const PrsHybrid> nominal = make_document001_machine();
  std::shared_ptr<const PrsHybrid> truth = nominal->with_errors(document001_table1_errors());
  std::vector<Pose> poses = cal::doc001::pose_set();
};

const Experiment& experiment() {
  static const Experiment e;
  return e;
}

struct Outcome {
  cal::IdentifyResult result;
  double before = 0, after = 0;
  double rms_position = 0, max_position = 0;
};

Outcome run(Method method, bool torsion, double lambda = 0) {
  const Experiment& e = experiment();
  const auto data = cal::doc001::simulate(*e.nominal, *e.truth, e.poses, kSeed, torsion);
  cal::IdentifyOptions opt;
  opt.method = method;
  opt.ridge_lambda = lambda;
  opt.max_iterations = method == Method::ridge ? 1000 : 150;
  Outcome o;
  o.result = cal::identify(*e.nominal, data, opt);
  const auto identified = std::static_pointer_cast<const PrsHybrid>(e.nominal->with_values(o.result.values));
  o.before = cal::doc001::max_tip_error_z700(*e.nominal, *e.truth);
  o.after = cal::doc001::max_tip_error_z700(*identified, *e.truth);
  const Eigen::VectorXd res = cal::residuals(*identified, data);
  const int rows = torsion ? 6 : 5;
  double sum = 0;
  for (std::size_t i = 0; i < data.size(); ++i) {
    const double d = res.segment(static_cast<Eigen::Index>(i) * rows, 3).norm();
    sum += d * d;
    o.max_position = std::max(o.max_position, d);
  }
  o.rms_position = std::sqrt(sum / static_cast<double>(data.size()));
  std::printf("method %d torsion %d: before %.4f mm after %.5f mm, %d iterations, %.4f s, cost %.3g -> %.3g, "
              "lambda %.3g, residual rms %.5f max %.5f mm\n  %s\n",
              static_cast<int>(method), torsion ? 1 : 0, o.before, o.after, o.result.iterations,
              o.result.seconds, o.result.initial_cost, o.result.final_cost, o.result.lambda, o.rms_position,
              o.max_position, o.result.message.c_str());
  std::printf("  rank %d of %d, condition %.3g, held:", o.result.start.rank, o.result.start.parameters,
              o.result.start.condition);
  for (int k : o.result.held) std::printf(" %s", e.nominal->parameters()[static_cast<std::size_t>(k)].name.c_str());
  std::printf("\n");
  for (const auto& c : o.result.start.combinations) std::printf("  null: %s\n", c.c_str());
  return o;
}

void record(const Outcome& o) {
  testing::Test::RecordProperty("before_mm", std::to_string(o.before));
  testing::Test::RecordProperty("after_mm", std::to_string(o.after));
  testing::Test::RecordProperty("iterations", o.result.iterations);
  testing::Test::RecordProperty("seconds", std::to_string(o.result.seconds));
}

void expect_reproduces_measurements(const Outcome& o) {
  // Noise is uniform ±0.01 mm per component: |dp| ≤ 0.0173 mm, rms ≈ 0.01 mm.
  EXPECT_LE(o.rms_position, 0.012);
  EXPECT_LE(o.max_position, 0.02);
  EXPECT_LT(o.result.final_cost, 1e-4 * o.result.initial_cost);
}

TEST(CalibrationDoc001, PoseSetAndBefore) {
  const Experiment& e = experiment();
  ASSERT_EQ(e.poses.size(), 27u);
  EXPECT_NEAR(cal::doc001::max_tip_error_z700(*e.nominal, *e.truth), 6.548, 0.01);
  EXPECT_LT(cal::doc001::max_tip_error_z700(*e.truth, *e.truth), 1e-9);
}

TEST(CalibrationDoc001, LeastSquares6Dof) {
  const Outcome o = run(Method::least_squares, true);
  record(o);
  ASSERT_TRUE(o.result.usable) << o.result.message;
  EXPECT_LE(o.after, kPaperBest);
  expect_reproduces_measurements(o);
}

TEST(CalibrationDoc001, PsiSubstitution5Dof) {
  const Outcome o = run(Method::psi_substitution, false);
  record(o);
  ASSERT_TRUE(o.result.usable) << o.result.message;
  EXPECT_LE(o.after, kPaperBest);
  expect_reproduces_measurements(o);
}

TEST(CalibrationDoc001, Ridge5Dof) {
  const Outcome o = run(Method::ridge, false);
  record(o);
  ASSERT_TRUE(o.result.usable) << o.result.message;
  EXPECT_LE(o.after, kPaperBest);
  expect_reproduces_measurements(o);
}

TEST(CalibrationDoc001, Ridge5DofGcvBeatsFixedLambda) {
  // Our ridge is the penalised estimate (λ‖x − x₀‖² in the cost). The paper's λ = 1e-3 is a
  // damping of its iteration; as a penalty it over-regularises the mm-scale errors, which GCV
  // avoids: the GCV λ is smaller and its result better.
  const Outcome fixed = run(Method::ridge, false, 1e-3);
  const Outcome gcv = run(Method::ridge, false);
  ASSERT_TRUE(fixed.result.usable) << fixed.result.message;
  EXPECT_LT(gcv.result.lambda, 1e-3);
  EXPECT_LT(gcv.after, fixed.after);
  EXPECT_GT(fixed.after, kPaperBest);
}

TEST(CalibrationDoc001, LeastSquares5Dof) {
  // Plain least squares on the 5 measured components: the torsion-only directions are simply
  // unobserved; LM's damping keeps them near the start.
  const Outcome o = run(Method::least_squares, false);
  record(o);
  EXPECT_TRUE(o.result.usable) << o.result.message;
}

TEST(CalibrationDoc001, FixedParametersStay) {
  const Experiment& e = experiment();
  const auto data = cal::doc001::simulate(*e.nominal, *e.truth, e.poses, kSeed, true);
  cal::IdentifyOptions opt;
  opt.fixed = {0, 11, 32};
  const auto r = cal::identify(*e.nominal, data, opt);
  ASSERT_GE(r.values.size(), 33u);
  EXPECT_EQ(r.values[0], 0.0);
  EXPECT_EQ(r.values[11], 0.0);
  EXPECT_EQ(r.values[32], 0.0);
  EXPECT_GT(std::abs(r.values[1]), 1e-3);
  opt.fixed = {1000};
  EXPECT_THROW((void)cal::identify(*e.nominal, data, opt), postproc::Error);
  EXPECT_THROW((void)cal::identify(*e.nominal, std::span<const cal::Measurement>{}, {}), postproc::Error);
}

}  // namespace
