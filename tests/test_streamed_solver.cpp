// The streamed solver of identify() (issue 21: a million measurement rows in seconds, memory
// independent of their number) against the Ceres solver on the same data: the same parameters,
// registration, uncertainties and identifiability, for every kind of problem it takes (6-DoF
// poses, positions in an instrument frame, a robust loss, ridge, hexapod strut readings); the
// compressed Jacobian against the full one; the result independent of the thread count.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "postproc/calibration/identify.hpp"
#include "postproc/calibration/plan.hpp"
#include "postproc/error.hpp"
#include "postproc/kinematics/model.hpp"
#include "postproc/kinematics/prs_hybrid.hpp"
#include "postproc/machine/machine.hpp"
#include "calibration_support.hpp"
#include "src/calibration/jacobian_compression.hpp"

namespace {

using namespace postproc;
using cal::Measurement;
using cal::MeasurementKind;

machine::Machine load(const std::string& rel) {
  gcode::DiagnosticSink sink;
  auto m = machine::load_machine(pptest::sample_path(rel), sink);
  if (!m) throw std::runtime_error("sample machine does not load: " + rel);
  return *m;
}

std::vector<Measurement> simulate(const kin::Model& truth, const kin::Model& start, int n, MeasurementKind kind,
                                  double noise_mm, unsigned seed) {
  cal::SimulateOptions o;
  o.kind = kind;
  o.noise_mm = noise_mm;
  o.noise_deg = noise_mm * 0.5;
  o.seed = seed;
  return cal::simulate_measurements(truth, start, pptest::random_joints(start, n, seed, 0.1), o);
}

cal::IdentifyResult solve(const kin::Model& start, const std::vector<Measurement>& data, cal::IdentifyOptions o,
                          cal::Solver solver) {
  o.solver = solver;
  cal::IdentifyResult r = cal::identify(start, data, o);
  EXPECT_EQ(r.solver, solver);
  EXPECT_TRUE(r.usable) << r.message;
  EXPECT_TRUE(r.converged) << r.message;
  return r;
}

/// Both solvers reach the same minimum: every identified parameter within `rel` of its standard
/// deviation, the same σ, cost, held set, identifiability and uncertainties.
void expect_same(const cal::IdentifyResult& a, const cal::IdentifyResult& b, double rel) {
  ASSERT_EQ(a.identified, b.identified);
  EXPECT_EQ(a.held, b.held);
  for (int k : a.identified) {
    const auto i = static_cast<std::size_t>(k);
    ASSERT_TRUE(std::isfinite(a.stddev[i]) && a.stddev[i] > 0) << k;
    EXPECT_LE(std::abs(a.values[i] - b.values[i]), rel * a.stddev[i])
        << "parameter " << k << " " << a.values[i] << " " << b.values[i] << " σ " << a.stddev[i] << " " << a.message
        << " / " << b.message;
    EXPECT_NEAR(a.stddev[i], b.stddev[i], 1e-6 * a.stddev[i]) << "parameter " << k;
  }
  EXPECT_NEAR(a.sigma, b.sigma, 1e-6 * a.sigma);
  EXPECT_NEAR(a.final_cost, b.final_cost, 1e-6 * a.final_cost);
  EXPECT_NEAR(a.initial_cost, b.initial_cost, 1e-12 * a.initial_cost);
  EXPECT_EQ(a.start.rank, b.start.rank);
  EXPECT_EQ(a.start.rows, b.start.rows);
  EXPECT_NEAR(a.solution.condition, b.solution.condition, 1e-6 * a.solution.condition);
  ASSERT_EQ(a.frames.size(), b.frames.size());
  for (std::size_t f = 0; f < a.frames.size(); ++f) {
    EXPECT_LE((a.frames[f].t - b.frames[f].t).norm(), 1e-7) << a.frames[f].name;  // 0.1 nm
    EXPECT_LE((a.frames[f].r - b.frames[f].r).norm(), 1e-9) << a.frames[f].name;
  }
  ASSERT_EQ(a.files.size(), b.files.size());
  for (std::size_t f = 0; f < a.files.size(); ++f) EXPECT_NEAR(a.files[f].chi2, b.files[f].chi2, 1e-6 * a.files[f].chi2);
}

TEST(StreamedSolver, AgreesWithCeresOnSixDofPoses) {
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const auto start = pptest::zero_errors(*mach.actual);
  const auto data = simulate(*mach.actual, *start, 300, MeasurementKind::pose, 0.001, 3);
  const auto c = solve(*start, data, {}, cal::Solver::ceres);
  const auto s = solve(*start, data, {}, cal::Solver::streamed);
  expect_same(c, s, 1e-6);
  EXPECT_GT(s.iterations, 0);
}

TEST(StreamedSolver, AgreesWithCeresWithAnInstrumentFrame) {
  // Positions seen by a tracker standing 10 µm and 5 arcsec away from the workpiece frame, its
  // placement estimated with the machine's parameters.
  const auto mach = load("machines/trunnion_ac_fanuc.toml");
  const auto start = pptest::zero_errors(*mach.actual);
  auto data = simulate(*mach.actual, *start, 400, MeasurementKind::position, 0.001, 5);
  const Eigen::Matrix3d r =
      Eigen::AngleAxisd(5 * kin::kPi / 180 / 3600, Eigen::Vector3d(1, 2, 2).normalized()).toRotationMatrix();
  const Eigen::Vector3d t(0.010, -0.006, 0.008);
  for (Measurement& m : data) {
    m.measured.p = r.transpose() * (m.measured.p - t);
    m.measured.r = r.transpose() * m.measured.r;
    m.source.frame = "tracker";
    m.source.free = cal::kTranslation | cal::kRotation;
  }
  const auto c = solve(*start, data, {}, cal::Solver::ceres);
  const auto s = solve(*start, data, {}, cal::Solver::streamed);
  ASSERT_EQ(s.frames.size(), 1u);
  // Both stop on their tolerances within 1e-4 σ of each other (a flat valley: the placement
  // and the parameters it nearly imitates).
  expect_same(c, s, 1e-4);
}

TEST(StreamedSolver, AgreesWithCeresUnderARobustLoss) {
  // Iteratively reweighted steps and Ceres' corrected ones stop at the same stationary point.
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const auto start = pptest::zero_errors(*mach.actual);
  auto data = simulate(*mach.actual, *start, 200, MeasurementKind::pose, 0.001, 7);
  data[11].measured.p += Eigen::Vector3d(0.3, -0.2, 0.25);  // a mis-read sphere
  for (cal::Loss loss : {cal::Loss::huber, cal::Loss::cauchy}) {
    cal::IdentifyOptions o;
    o.loss = loss;
    o.loss_scale = 0.003;
    const auto c = solve(*start, data, o, cal::Solver::ceres);
    const auto s = solve(*start, data, o, cal::Solver::streamed);
    expect_same(c, s, 1e-4);
  }
}

TEST(StreamedSolver, AgreesWithCeresWithRidge) {
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const auto start = pptest::zero_errors(*mach.actual);
  const auto data = simulate(*mach.actual, *start, 60, MeasurementKind::position, 0.002, 9);
  cal::IdentifyOptions o;
  o.method = cal::Method::ridge;  // λ by GCV, from the compressed Jacobian in both
  const auto c = solve(*start, data, o, cal::Solver::ceres);
  const auto s = solve(*start, data, o, cal::Solver::streamed);
  EXPECT_GT(c.lambda, 0);
  EXPECT_EQ(c.lambda, s.lambda);
  expect_same(c, s, 1e-6);
}

TEST(StreamedSolver, AgreesWithCeresOnHexapodStrutReadings) {
  const auto mach = load("machines/hexapod_doc003.toml");
  const std::vector<Measurement> data = pptest::hexapod_strut_readings(*mach.actual, *mach.nominal, 40);
  ASSERT_EQ(data.size(), 40u);
  const auto c = solve(*mach.nominal, data, {}, cal::Solver::ceres);
  const auto s = solve(*mach.nominal, data, {}, cal::Solver::streamed);
  expect_same(c, s, 1e-5);
}

TEST(StreamedSolver, AgreesWithCeresOnThePrsHybridAndNumericDerivatives) {
  // Document 001's 3-PRS head (its own analytic Jacobian, one thread) from 6-DoF poses with
  // ±10 µm noise; then the B/C trunnion with central differences for every parameter.
  const auto nominal = kin::make_document001_machine();
  const auto truth = nominal->with_errors(kin::document001_table1_errors());
  const auto data = cal::doc001::simulate(*nominal, *truth, cal::doc001::pose_set(), 3, true, 0.01, 0.01);
  const auto c = solve(*nominal, data, {}, cal::Solver::ceres);
  const auto s = solve(*nominal, data, {}, cal::Solver::streamed);
  expect_same(c, s, 1e-5);

  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const auto start = pptest::zero_errors(*mach.actual);
  const auto poses = simulate(*mach.actual, *start, 80, MeasurementKind::pose, 0.001, 17);
  cal::IdentifyOptions numeric;
  numeric.numeric_derivatives = true;
  expect_same(solve(*start, poses, numeric, cal::Solver::ceres), solve(*start, poses, numeric, cal::Solver::streamed),
              1e-5);
}

TEST(StreamedSolver, TheThreadCountDoesNotChangeTheResult) {
  // Chunks are combined in a fixed order: bit for bit the same on 1 and 2 threads.
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const auto start = pptest::zero_errors(*mach.actual);
  const auto data = simulate(*mach.actual, *start, 3000, MeasurementKind::position, 0.001, 11);
  cal::IdentifyOptions one, two;
  one.threads = 1;
  two.threads = 2;
  const auto a = solve(*start, data, one, cal::Solver::streamed);
  const auto b = solve(*start, data, two, cal::Solver::streamed);
  EXPECT_EQ(a.values, b.values);
  EXPECT_EQ(a.sigma, b.sigma);
  EXPECT_EQ(a.iterations, b.iterations);
}

TEST(StreamedSolver, AutomaticChoiceFollowsTheRowCount) {
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const auto start = pptest::zero_errors(*mach.actual);
  const auto small = simulate(*mach.actual, *start, 100, MeasurementKind::position, 0.001, 13);
  EXPECT_EQ(cal::identify(*start, small).solver, cal::Solver::ceres);
  const auto large = simulate(*mach.actual, *start, static_cast<int>(cal::kStreamedRows / 3), MeasurementKind::position,
                              0.001, 13);
  const auto r = cal::identify(*start, large);
  EXPECT_EQ(r.solver, cal::Solver::streamed);
  EXPECT_TRUE(r.converged) << r.message;
  EXPECT_LT(r.sigma, 0.001);
  // Bounds need Ceres: the automatic choice takes it, an explicit streamed request is refused.
  cal::IdentifyOptions bounded;
  bounded.bounds.push_back({r.identified.front(), {-1.0, 1.0}});
  EXPECT_EQ(cal::identify(*start, large, bounded).solver, cal::Solver::ceres);
  bounded.solver = cal::Solver::streamed;
  EXPECT_THROW((void)cal::identify(*start, small, bounded), Error);
  cal::IdentifyOptions psi;
  psi.method = cal::Method::psi_substitution;
  psi.solver = cal::Solver::streamed;
  EXPECT_THROW((void)cal::identify(*start, small, psi), Error);
}

TEST(StreamedSolver, TheCompressedJacobianKeepsNormsAndInnerProducts) {
  // RᵀR = JᵀJ and Rᵀ(Qᵀr) = Jᵀr against the full Jacobian of cal::linearise, over several
  // chunks and every measurement kind of a serial chain.
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const auto start = pptest::zero_errors(*mach.actual);
  std::vector<Measurement> data;
  unsigned seed = 20;
  for (MeasurementKind kind : {MeasurementKind::pose, MeasurementKind::position, MeasurementKind::direction}) {
    auto part = simulate(*mach.actual, *start, 700, kind, 0.001, ++seed);
    data.insert(data.end(), part.begin(), part.end());
  }
  std::vector<int> cols;
  for (int k = 0; k < static_cast<int>(start->parameters().size()); ++k)
    if (start->parameters()[static_cast<std::size_t>(k)].error) cols.push_back(k);
  Eigen::VectorXd res;
  Eigen::MatrixXd jac;
  cal::linearise(*start, data, cols, res, jac);
  const std::vector<cal::lsq::Weights> w(data.size(), cal::lsq::Weights{1, cal::kOrientationWeight});
  cal::lsq::LineariseOptions o;
  o.threads = 2;
  o.per_measurement = true;
  const cal::lsq::Linearised lin = cal::lsq::linearise(*start, data, cols, w, {}, {}, {}, false, o);
  ASSERT_TRUE(lin.ok());
  EXPECT_EQ(lin.rows, res.size());
  EXPECT_NEAR(lin.squared, res.squaredNorm(), 1e-12 * res.squaredNorm());
  const Eigen::MatrixXd r = lin.r();
  const Eigen::MatrixXd jtj = jac.transpose() * jac;
  EXPECT_LE((r.transpose() * r - jtj).norm(), 1e-12 * jtj.norm());
  const Eigen::VectorXd jtr = jac.transpose() * res;
  EXPECT_LE((r.transpose() * lin.qtr() - jtr).norm(), 1e-12 * jac.norm() * res.norm());
  double sum = 0;
  for (double s : lin.per_measurement) sum += s;
  EXPECT_NEAR(sum, lin.squared, 1e-12 * lin.squared);
  // A measurement the model cannot evaluate is named, not skipped.
  auto bad = data;
  bad[1500].q[0] = std::numeric_limits<double>::quiet_NaN();
  const cal::lsq::Linearised failed = cal::lsq::linearise(*start, bad, cols, w, {}, {}, {}, false, o);
  EXPECT_EQ(failed.failed, 1500);
}

}  // namespace
