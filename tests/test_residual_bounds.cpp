// Uncertainty to the cut (issue 19): the 95 % bound per block of a compensated program, from the
// covariance a calibration leaves in the machine file, covers the error the true machine leaves
// on ≥ 95 % of the blocks and is not absurdly loose (its maximum within 5× of the true maximum);
// the [uncertainty] table round-trips through the machine file; χ² quantiles.
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include <fmt/format.h>

#include "postproc/calibration/identify.hpp"
#include "postproc/calibration/machine_update.hpp"
#include "postproc/calibration/plan.hpp"
#include "postproc/compensation/compensate.hpp"
#include "postproc/compensation/residual_bounds.hpp"
#include "postproc/error.hpp"
#include "postproc/machine/machine.hpp"
#include "calibration_support.hpp"
#include "sample_machine.hpp"
#include "support.hpp"

namespace {

using namespace postproc;
namespace mc = postproc::machine;
namespace gc = postproc::gcode;

const std::string kSamples = std::string(POSTPROC_SOURCE_DIR) + "/samples/";

using pptest::read_file;

/// Random joint vectors inside the travel, 5 % of it from the ends.
std::vector<postproc::kin::JointVector> random_joints(const postproc::kin::Model& m, int n, unsigned seed) {
  return pptest::random_joints(m, n, seed, 0.05);
}

/// The nominal machine file calibrated from simulated measurements of `truth`: [errors] and
/// [uncertainty] written as `calibrate` writes them, and read back.
mc::Machine calibrated(const std::string& nominal_text, const mc::Machine& nominal, const kin::Model& truth, unsigned seed,
                       double noise_mm) {
  cal::SimulateOptions o;
  o.kind = cal::MeasurementKind::position;
  o.noise_mm = noise_mm;
  o.seed = seed;
  const auto joints = random_joints(*nominal.actual, 40, seed);
  const auto data = cal::simulate_measurements(truth, *nominal.nominal, joints, o);
  const cal::IdentifyResult r = cal::identify(*nominal.actual, data);
  cal::ErrorsTable t;
  t.model = nominal.actual.get();
  t.values = r.values;
  t.stddev = r.stddev;
  t.identified = r.identified;
  std::string text = cal::replace_toml_table(nominal_text, "errors", cal::errors_table_toml(t));
  text = cal::replace_toml_table(text, "uncertainty",
                                 cal::uncertainty_table_toml(*nominal.actual, r.identified, r.covariance, joints));
  gc::DiagnosticSink sink;
  auto m = mc::parse_machine("calibrated.toml", text, sink);
  for (const auto& d : sink.stored()) ADD_FAILURE() << gc::format(d);
  if (!m) throw std::runtime_error("the calibrated machine file does not read back");
  // The [errors] table is written to 0.1 nm / 0.0001 arcsec: the model is the file's, as compensate sees it.
  return *m;
}

struct Written {
  std::string text;
  std::vector<std::uint64_t> line_map;
};

Written compensate(const mc::Machine& m, const std::string& program) {
  const gc::Dialect d = *gc::make_dialect(m.dialect_name, m.dialect_options);
  pptest::TempDir dir;
  const std::string path = dir.file("out.nc");
  Written w;
  comp::CompensateOptions opt;
  opt.line_map = &w.line_map;
  opt.tool_version = "test";
  gc::DiagnosticSink sink;
  {
    gc::LineReader reader{std::string_view(program)};
    io::OutputFile out(path);
    (void)comp::compensate(reader, "in.nc", d, m, opt, out, sink);
    if (sink.has_errors()) throw std::runtime_error("compensate refused the program");
    out.commit();
  }
  w.text = read_file(path);
  return w;
}

TEST(ChiQuantile, MatchesTables) {
  // χ² 95 % quantiles: 3 → 7.815, 16 → 26.296, 30 → 43.773 (the Wilson–Hilferty approximation is
  // within 0.5 % there; the k of a bound is its square root).
  EXPECT_NEAR(comp::chi_quantile_root(3, 0.95), std::sqrt(7.815), 0.01);
  EXPECT_NEAR(comp::chi_quantile_root(16, 0.95), std::sqrt(26.296), 0.01);
  EXPECT_NEAR(comp::chi_quantile_root(30, 0.95), std::sqrt(43.773), 0.01);
  EXPECT_NEAR(comp::chi_quantile_root(16, 0.99), std::sqrt(32.000), 0.02);
}

TEST(ResidualBounds, CoverTheTrueResidualAndAreNotAbsurdlyLoose) {
  const std::string nominal_text = read_file(kSamples + "machines/trunnion_bc_fanuc_nominal.toml");
  const mc::Machine nominal = pptest::sample_machine("trunnion_bc_fanuc_nominal.toml");
  const mc::Machine truth = pptest::sample_machine("trunnion_bc_fanuc.toml");
  const std::string program = read_file(kSamples + "programs/impeller_axes_bc.nc");
  const gc::Dialect d = *gc::make_dialect(nominal.dialect_name, nominal.dialect_options);
  std::size_t blocks = 0, covered = 0;
  for (unsigned seed = 1; seed <= 10; ++seed) {
    const mc::Machine m = calibrated(nominal_text, nominal, *truth.actual, seed, 0.002);
    ASSERT_TRUE(m.uncertainty.has_value());
    const Written w = compensate(m, program);
    const comp::BoundsResult b = comp::residual_bounds(w.text, d, m);
    ASSERT_GT(b.blocks.size(), 100u);
    EXPECT_EQ(b.outside_region, 0u) << "the simulated poses cover the program's range";
    // The true residual of each block: the true machine against the calibrated model at the joints
    // the controller commands (the calibrated model puts the tool where the program means, up to
    // the rounding the bound adds separately).
    double worst_true = 0, worst_bound = 0;
    std::size_t here = 0;
    for (const comp::BlockBound& bb : b.blocks) {
      kin::Pose real, model;
      const auto models_truth = truth.actual->with_values([&] {
        std::vector<double> v = truth.actual->values();
        const int k = truth.actual->parameter_index("tool.length");
        if (k >= 0) v[static_cast<std::size_t>(k)] = bb.tool_length;
        return v;
      }());
      const auto models_cal = m.actual->with_values([&] {
        std::vector<double> v = m.actual->values();
        const int k = m.actual->parameter_index("tool.length");
        if (k >= 0) v[static_cast<std::size_t>(k)] = bb.tool_length;
        return v;
      }());
      ASSERT_TRUE(models_truth->forward(bb.joints, real).ok());
      ASSERT_TRUE(models_cal->forward(bb.joints, model).ok());
      const double err = (real.p - model.p).norm();
      const double statistical = bb.tip_mm - bb.rounding_mm;
      here += err <= statistical ? 1 : 0;
      worst_true = std::max(worst_true, err);
      worst_bound = std::max(worst_bound, statistical);
    }
    EXPECT_LE(worst_bound, 5 * worst_true) << "seed " << seed << ": the bound is absurdly loose";
    blocks += b.blocks.size();
    covered += here;
  }
  EXPECT_GE(static_cast<double>(covered), 0.95 * static_cast<double>(blocks)) << covered << " of " << blocks;
}

TEST(ResidualBounds, NeedTheUncertaintyTable) {
  const mc::Machine nominal = pptest::sample_machine("trunnion_bc_fanuc.toml");
  const gc::Dialect d = *gc::make_dialect(nominal.dialect_name, nominal.dialect_options);
  EXPECT_THROW((void)comp::residual_bounds("G0 X1\n", d, nominal), Error);
}

TEST(UncertaintyTable, RefusesWhatIsNotACovariance) {
  const std::string base = read_file(kSamples + "machines/trunnion_bc_fanuc_nominal.toml");
  struct Case {
    std::string table;
    std::string code;
  };
  const std::vector<Case> cases = {
      {"[uncertainty]\nparameters = [\"EX0C\", \"NOPE\"]\ncovariance = [[1e-6, 0], [0, 1e-6]]\n", "PP-M002"},
      {"[uncertainty]\nparameters = [\"EX0C\", \"EY0C\"]\ncovariance = [[1e-6, 0]]\n", "PP-M007"},
      {"[uncertainty]\nparameters = [\"EX0C\", \"EY0C\"]\ncovariance = [[1e-6, 2e-6], [2e-6, 1e-6]]\n", "PP-M007"},
      {"[uncertainty]\nparameters = [\"EX0C\", \"EY0C\"]\ncovariance = [[1e-6, 0], [1e-7, 1e-6]]\n", "PP-M007"},
      {"[uncertainty]\nparameters = [\"EX0C\"]\ncovariance = [[1e-6]]\nregion = { X = [10, -10] }\n", "PP-M007"},
      {"[uncertainty]\nparameters = [\"EX0C\"]\ncovariance = [[1e-6]]\nextra = 1\n", "PP-M002"},
  };
  for (const Case& c : cases) {
    gc::DiagnosticSink sink;
    EXPECT_FALSE(mc::parse_machine("m.toml", cal::replace_toml_table(base, "uncertainty", c.table), sink)) << c.table;
    bool found = false;
    for (const auto& diag : sink.stored()) found = found || diag.code == c.code;
    EXPECT_TRUE(found) << c.table;
  }
  gc::DiagnosticSink sink;
  const auto ok = mc::parse_machine(
      "m.toml",
      cal::replace_toml_table(base, "uncertainty",
                              "[uncertainty]\nparameters = [\"EX0C\"]\ncovariance = [[1e-6]]\nregion = { X = [-10, 10], B = [-30, 45] }\n"),
      sink);
  ASSERT_TRUE(ok);
  ASSERT_TRUE(ok->uncertainty);
  EXPECT_EQ(ok->uncertainty->parameters.size(), 1u);
  const int b = [&] {
    for (int j = 0; j < ok->actual->joint_count(); ++j)
      if (ok->actual->joints()[static_cast<std::size_t>(j)].name == "B") return j;
    return -1;
  }();
  ASSERT_GE(b, 0);
  EXPECT_DOUBLE_EQ(ok->uncertainty->region_max[static_cast<std::size_t>(b)], 45.0);
}

}  // namespace
