// Calibration engine (issue 5): measurement files (round trip, located errors), the calibrated
// machine file, Ceres GradientChecker on the analytic identification Jacobians, identification of
// serial and hexapod machines against ground truth with tolerances stated per test.
#include <gtest/gtest.h>

#include <ceres/ceres.h>
#include <ceres/gradient_checker.h>

#include <cmath>
#include <fstream>
#include <random>

#include <fmt/format.h>
#include <string>

#include "postproc/calibration/csv.hpp"
#include "postproc/calibration/identify.hpp"
#include "postproc/calibration/machine_update.hpp"
#include "postproc/calibration/measurement.hpp"
#include "postproc/calibration/report.hpp"
#include "postproc/error.hpp"
#include "postproc/kinematics/hexapod.hpp"
#include "postproc/kinematics/serial.hpp"
#include "postproc/machine/machine.hpp"
#include "calibration_support.hpp"

namespace {

using namespace postproc;
using cal::Measurement;
using cal::MeasurementKind;

using pptest::sample_path;
std::string sample(const std::string& rel) { return sample_path(rel); }

machine::Machine load(const std::string& rel) {
  gcode::DiagnosticSink sink;
  auto m = machine::load_machine(sample(rel), sink);
  if (!m) throw std::runtime_error("sample machine does not load: " + rel);
  return *m;
}

using pptest::random_joints;
using pptest::zero_errors;

/// 6-DoF poses of `truth` at q with uniform noise ±mm per component and a rotation ±deg per component.
std::vector<Measurement> poses(const kin::Model& truth, const std::vector<kin::JointVector>& qs, double mm, double deg,
                               unsigned seed, bool torsion = true) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Measurement> out;
  for (const auto& q : qs) {
    Measurement m;
    m.q = q;
    if (!truth.forward(q, m.measured).ok()) continue;
    m.measured.p += mm * Eigen::Vector3d(u(rng), u(rng), u(rng));
    const Eigen::Vector3d w = deg * kin::kDeg * Eigen::Vector3d(u(rng), u(rng), u(rng));
    if (w.norm() > 0) m.measured.r = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() * m.measured.r;
    m.has_torsion = torsion;
    m.label = "p" + std::to_string(out.size() + 1);
    out.push_back(m);
  }
  return out;
}

// ------------------------------------------------------------------------------------------
// Measurement files

TEST(MeasurementFiles, WriteReadRoundTripPerKind) {
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const kin::Model& model = *mach.actual;
  const auto qs = random_joints(model, 5, 7);
  for (MeasurementKind kind : {MeasurementKind::pose, MeasurementKind::position, MeasurementKind::direction}) {
    for (bool torsion : {true, false}) {
      auto data = poses(model, qs, 0.001, 0.001, 3, torsion);
      for (auto& m : data) m.kind = kind;
      data[2].validate = true;
      const std::string text = cal::write_measurements(data, model, {"made by the test"});
      gcode::DiagnosticSink sink;
      auto table = cal::CsvTable::parse("rt.csv", text, sink);
      ASSERT_TRUE(table);
      std::vector<Measurement> back;
      ASSERT_TRUE(cal::read_measurements(*table, model, back)) << text;
      ASSERT_EQ(back.size(), data.size());
      for (std::size_t i = 0; i < data.size(); ++i) {
        EXPECT_EQ(back[i].kind, kind);
        EXPECT_EQ(back[i].validate, i == 2);
        EXPECT_EQ(back[i].label, data[i].label);
        EXPECT_LT((back[i].q - data[i].q).norm(), 1e-7);
        if (kind != MeasurementKind::direction) {
          EXPECT_LT((back[i].measured.p - data[i].measured.p).norm(), 1e-8);
        }
        if (kind != MeasurementKind::position) {
          EXPECT_LT((back[i].measured.axis() - data[i].measured.axis()).norm(), 1e-11);
        }
        const bool has_torsion = kind == MeasurementKind::pose && torsion;
        EXPECT_EQ(back[i].has_torsion, has_torsion);
        if (has_torsion) {
          EXPECT_LT((back[i].measured.r - data[i].measured.r).norm(), 1e-11);
        }
      }
    }
  }
}

TEST(MeasurementFiles, UnitsInColumnNamesAreConverted) {
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const std::string text =
      "# kind: positions\n"
      "id,X [um],Y_mm,Z_mm,B_rad,C_deg,x_um,y_mm,z_in\n"
      "a,1000,2,3,0.1,45,1500,2,1\n";
  gcode::DiagnosticSink sink;
  auto t = cal::CsvTable::parse("u.csv", text, sink);
  ASSERT_TRUE(t);
  std::vector<Measurement> out;
  ASSERT_TRUE(cal::read_measurements(*t, *mach.actual, out));
  ASSERT_EQ(out.size(), 1u);
  EXPECT_NEAR(out[0].q[mach.joint_of_axis[0]], 1.0, 1e-12);                 // X 1000 µm = 1 mm
  EXPECT_NEAR(out[0].q[mach.joint_of_axis[4]], 0.1 / kin::kDeg, 1e-9);      // B 0.1 rad in degrees
  EXPECT_NEAR(out[0].measured.p.x(), 1.5, 1e-12);
  EXPECT_NEAR(out[0].measured.p.z(), 25.4, 1e-12);
}

TEST(MeasurementFiles, AttitudesGiveTheToolAxis) {
  // Document 000: the stem along the tool axis extends by travel / cos per axis.
  const auto mach = load("machines/hybrid_3prs_doc001.toml");
  const Eigen::Vector3d stem = Eigen::Vector3d(0.3, -0.2, -1).normalized();
  const std::string text = fmt::format(
      "# kind: attitudes\nX_mm,Y_mm,q1_mm,q2_mm,q3_mm,travel_x_mm,stem_x_mm,travel_y_mm,stem_y_mm\n"
      "0,0,100,110,120,1,{:.12f},1,{:.12f}\n"
      "0,0,100,110,120,1,{:.12f},-1,{:.12f}\n",
      1 / stem.x(), 1 / stem.y(), 1 / stem.x(), -1 / stem.y());
  gcode::DiagnosticSink sink;
  auto t = cal::CsvTable::parse("att.csv", text, sink);
  ASSERT_TRUE(t);
  std::vector<Measurement> out;
  ASSERT_TRUE(cal::read_measurements(*t, *mach.actual, out));
  ASSERT_EQ(out.size(), 2u);
  for (const auto& m : out) {
    EXPECT_EQ(m.kind, MeasurementKind::direction);
    EXPECT_LT((m.measured.axis() + stem).norm(), 1e-9);
  }
}

TEST(MeasurementFiles, SingleIndicatorRecordsGiveOneCosineEach) {
  // A tool tilted in XZ has no usable Y record: X alone, or X and Z, give one cosine per record
  // (X and Z leave the sign of the Y cosine open); X and Y give the direction as before.
  const auto mach = load("machines/hybrid_3prs_doc001.toml");
  const Eigen::Vector3d stem = Eigen::Vector3d(0.3, -0.2, -1).normalized();
  const std::string text = fmt::format(
      "# kind: attitudes\nX_mm,Y_mm,q1_mm,q2_mm,q3_mm,travel_x_mm,stem_x_mm,travel_y_mm,stem_y_mm,travel_z_mm,stem_z_mm\n"
      "0,0,100,110,120,1,{0:.12f},,,,\n"
      "0,0,100,110,120,1,{0:.12f},,,2,{1:.12f}\n"
      "0,0,100,110,120,1,{0:.12f},1,{2:.12f},,\n"
      "0,0,100,110,120,,,,,,\n",
      1 / stem.x(), 2 / stem.z(), 1 / stem.y());
  gcode::DiagnosticSink sink;
  auto t = cal::CsvTable::parse("att.csv", text, sink);
  ASSERT_TRUE(t);
  std::vector<Measurement> out;
  EXPECT_FALSE(cal::read_measurements(*t, *mach.actual, out)) << "the row without any record is refused";
  ASSERT_EQ(sink.stored().size(), 1u);
  EXPECT_EQ(sink.stored()[0].where.line, 6u);
  ASSERT_EQ(out.size(), 4u);
  const Eigen::Vector3d o = -stem;  // the tool axis
  EXPECT_EQ(out[0].kind, MeasurementKind::axis_cosine);
  EXPECT_NEAR(out[0].cosine, o.x(), 1e-12);
  EXPECT_LT((out[0].measured.r.col(0) - Eigen::Vector3d::UnitX()).norm(), 1e-15);
  EXPECT_EQ(out[1].kind, MeasurementKind::axis_cosine);
  EXPECT_EQ(out[2].kind, MeasurementKind::axis_cosine);
  EXPECT_NEAR(out[2].cosine, o.z(), 1e-12);
  EXPECT_LT((out[2].measured.r.col(0) - Eigen::Vector3d::UnitZ()).norm(), 1e-15);
  EXPECT_EQ(out[3].kind, MeasurementKind::direction);
  EXPECT_LT((out[3].measured.axis() - o).norm(), 1e-9);
  for (const auto& m : out) EXPECT_NEAR(m.measured.r.determinant(), 1, 1e-12);
}

TEST(Identify, SingleCosineRowsLineariseExactly) {
  // The analytic rows of a single-cosine measurement against central differences of the residual.
  const auto mach = load("machines/hybrid_3prs_doc001.toml");
  const kin::Model& model = *mach.actual;
  Measurement m;
  m.kind = MeasurementKind::axis_cosine;
  m.q = kin::JointVector::Zero(model.joint_count());
  m.q << 20, -30, 100, 120, 90;
  m.measured.r.col(0) = Eigen::Vector3d(1, 2, -1).normalized();
  m.measured.r.col(2) = m.measured.r.col(0).unitOrthogonal();
  m.measured.r.col(1) = m.measured.r.col(2).cross(m.measured.r.col(0));
  m.cosine = 0.3;
  std::vector<int> cols;
  for (int k = 0; k < static_cast<int>(model.parameters().size()); ++k)
    if (model.parameters()[static_cast<std::size_t>(k)].error) cols.push_back(k);
  Eigen::VectorXd res;
  Eigen::MatrixXd jac;
  cal::linearise(model, std::span<const Measurement>(&m, 1), cols, res, jac);
  ASSERT_EQ(res.size(), 1);
  for (std::size_t c = 0; c < cols.size(); ++c) {
    const double h = model.parameters()[static_cast<std::size_t>(cols[c])].unit == "rad" ? 1e-7 : 1e-5;
    std::vector<double> a = model.values(), b = model.values();
    a[static_cast<std::size_t>(cols[c])] += h;
    b[static_cast<std::size_t>(cols[c])] -= h;
    const double fd = (cal::residuals(*model.with_values(a), std::span<const Measurement>(&m, 1))[0] -
                       cal::residuals(*model.with_values(b), std::span<const Measurement>(&m, 1))[0]) /
                      (2 * h);
    EXPECT_NEAR(jac(0, static_cast<Eigen::Index>(c)), fd, 1e-6 * std::max(1.0, std::abs(fd))) << cols[c];
  }
}

TEST(MeasurementFiles, EveryLineEndIsALineEnd) {
  // LF, CR LF and a CR alone (old Mac exports) give the same rows, with the same line numbers.
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  for (const std::string eol : {"\n", "\r\n", "\r"}) {
    const std::string text = "# kind: positions" + eol + "X_mm,Y_mm,Z_mm,B_deg,C_deg,x_mm,y_mm,z_mm" + eol +
                             "1,2,3,4,5,6,7,8" + eol + "2,3,4,5,6,7,8,9" + eol;
    gcode::DiagnosticSink sink;
    auto t = cal::CsvTable::parse("eol.csv", text, sink);
    ASSERT_TRUE(t) << "eol " << eol.size();
    std::vector<Measurement> out;
    ASSERT_TRUE(cal::read_measurements(*t, *mach.actual, out));
    ASSERT_EQ(out.size(), 2u);
    EXPECT_EQ(t->rows()[1].line, 4u);
    EXPECT_NEAR(out[1].measured.p.z(), 9.0, 1e-12);
  }
}

struct BadFile {
  const char* name;
  std::string text;
  std::string code;
  std::uint64_t line;
  std::uint32_t column;
};

TEST(MeasurementFiles, MalformedFilesGiveLocatedErrors) {
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const std::string head = "# kind: positions\nX_mm,Y_mm,Z_mm,B_deg,C_deg,x_mm,y_mm,z_mm\n";
  const BadFile cases[] = {
      {"no kind", "X_mm,Y_mm,Z_mm,B_deg,C_deg,x_mm,y_mm,z_mm\n1,2,3,4,5,6,7,8\n", "PP-C006", 1, 1},
      {"unknown kind", "# kind: photos\nX_mm\n1\n", "PP-C006", 2, 1},
      {"bad number", head + "1,2,3,4,5,6,seven,8\n", "PP-C003", 3, 13},
      {"short row", head + "1,2,3,4,5,6,7\n", "PP-C001", 3, 1},
      {"missing column", "# kind: positions\nX_mm,Y_mm,Z_mm,B_deg,C_deg,x_mm,y_mm\n1,2,3,4,5,6,7\n", "PP-C002", 2, 1},
      {"length unit for an angle", "# kind: positions\nX_mm,Y_mm,Z_mm,B_mm,C_deg,x_mm,y_mm,z_mm\n1,2,3,4,5,6,7,8\n",
       "PP-C004", 2, 16},
      {"no unit", "# kind: positions\nX,Y_mm,Z_mm,B_deg,C_deg,x_mm,y_mm,z_mm\n1,2,3,4,5,6,7,8\n", "PP-C004", 2, 1},
      {"unread column", "# kind: positions\nX_mm,Y_mm,Z_mm,B_deg,C_deg,x_mm,y_mm,z_mm,temp_mm\n1,2,3,4,5,6,7,8,9\n",
       "PP-C006", 2, 43},
      {"zero direction", "# kind: directions\nX_mm,Y_mm,Z_mm,B_deg,C_deg,i,j,k\n1,2,3,4,5,0,0,0\n", "PP-C005", 3, 11},
      {"stem shorter than travel",
       "# kind: attitudes\nX_mm,Y_mm,Z_mm,B_deg,C_deg,travel_x_mm,stem_x_mm,travel_y_mm,stem_y_mm\n1,2,3,4,5,2,1,1,3\n",
       "PP-C005", 3, 13},
      {"unclosed quote", head + "\"1,2,3,4,5,6,7,8\n", "PP-C001", 3, 1},
      {"header only", head, "PP-C001", 2, 1},
      {"struts on a serial machine", "# kind: struts\nX_mm\n1\n", "PP-C006", 2, 1},
      // Issue 21: values no machine or instrument could give are refused at the cell.
      {"angle beyond any machine", head + "1,2,3,1e6,5,6,7,8\n", "PP-C005", 3, 7},
      {"length beyond any machine", head + "1,2,3,4,5,1e308,7,8\n", "PP-C005", 3, 11},
      {"axis outside its travel", head + "1,2,3,111,5,6,7,8\n", "PP-C005", 3, 7},
      {"length beyond any machine in um", head.substr(0, 18) + "X_um,Y_mm,Z_mm,B_deg,C_deg,x_mm,y_mm,z_mm\n2e12,2,3,4,5,6,7,8\n",
       "PP-C005", 3, 1},
  };
  for (const BadFile& c : cases) {
    gcode::DiagnosticSink sink;
    std::vector<Measurement> out;
    auto t = cal::CsvTable::parse("bad.csv", c.text, sink);
    if (t) (void)cal::read_measurements(*t, *mach.actual, out);
    ASSERT_TRUE(sink.has_errors()) << c.name;
    const gcode::Diagnostic& d = sink.stored().front();
    EXPECT_EQ(d.code, c.code) << c.name << ": " << d.message;
    EXPECT_EQ(d.file, "bad.csv") << c.name;
    EXPECT_EQ(d.where.line, c.line) << c.name << ": " << d.message;
    EXPECT_EQ(d.where.column, c.column) << c.name << ": " << d.message;
    EXPECT_FALSE(d.message.empty());
  }
}

// ------------------------------------------------------------------------------------------
// Calibrated machine files

TEST(MachineUpdate, ErrorsTableReadsBackWithinItsDecimals) {
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const std::string text = [] {
    std::ifstream in(sample("machines/trunnion_bc_fanuc.toml"));
    return std::string(std::istreambuf_iterator<char>(in), {});
  }();
  const kin::Model& m = *mach.actual;
  std::vector<double> v = m.values();
  std::mt19937 rng(5);
  for (std::size_t k = 0; k < v.size(); ++k)
    if (m.parameters()[k].error)
      v[k] = m.parameters()[k].nominal +
             (m.parameters()[k].unit == "rad" ? 1e-4 : m.parameters()[k].unit == "ratio" ? 5e-5 : 0.05) *
                 std::uniform_real_distribution<double>(-1, 1)(rng);
  cal::ErrorsTable t;
  t.model = &m;
  t.values = v;
  t.stddev.assign(v.size(), 1e-4);
  for (std::size_t k = 0; k < v.size(); ++k)
    if (m.parameters()[k].error) t.identified.push_back(static_cast<int>(k));
  std::string out = cal::replace_toml_table(text, "errors", cal::errors_table_toml(t));
  const std::vector<std::string> header{"calibrated by postproc test", "  data x.csv"};
  out = cal::add_header_comment(out, header);
  // A second calibration replaces the header block instead of stacking it.
  const std::string twice = cal::add_header_comment(out, header);
  EXPECT_EQ(twice, out);
  gcode::DiagnosticSink sink;
  const auto back = machine::parse_machine("out.toml", out, sink);
  ASSERT_TRUE(back) << (sink.stored().empty() ? "" : sink.stored().front().message);
  for (std::size_t k = 0; k < v.size(); ++k) {
    // Written to 4 decimals: 0.0001 arcsec, 0.0001 µm, 0.0001 µm/m.
    const double tol = m.parameters()[k].unit == "rad"     ? 0.00005 / 3600 * kin::kDeg
                       : m.parameters()[k].unit == "ratio" ? 0.00005e-6
                                                           : 0.00005e-3;
    EXPECT_NEAR(back->actual->values()[k], v[k], tol * 1.0001) << m.parameters()[k].name;
  }
  // Everything outside [errors] is kept byte for byte.
  const auto tail = [](const std::string& s) { return s.substr(s.find("[error_motions")); };
  EXPECT_EQ(tail(out), tail(text));
}

TEST(MachineUpdate, InsertsTheTableWhenTheFileHasNone) {
  const std::string text = "# x\n[machine]\nname = \"a\"\n\n[axes.X]\ndecimals = 3\n";
  const std::string out = cal::replace_toml_table(text, "errors", "[errors]\nEX0X = \"1 um\"\n");
  EXPECT_EQ(out, "# x\n[machine]\nname = \"a\"\n\n[errors]\nEX0X = \"1 um\"\n\n[axes.X]\ndecimals = 3\n");
}

// ------------------------------------------------------------------------------------------
// GradientChecker: the residual Jacobians identify() uses (analytic identification Jacobians of
// the 3-PRS hybrid and the hexapod, differences elsewhere) against Ceres's own differences.

class LinearisedCost final : public ceres::CostFunction {
 public:
  LinearisedCost(const kin::Model& base, Measurement m, std::vector<int> cols)
      : base_(base), m_(std::move(m)), cols_(std::move(cols)) {
    set_num_residuals(cal::residual_rows(m_, base.joint_count()));
    mutable_parameter_block_sizes()->push_back(static_cast<int>(cols_.size()));
  }
  bool Evaluate(double const* const* x, double* residuals, double** jacobians) const override {
    std::vector<double> v = base_.values();
    for (std::size_t c = 0; c < cols_.size(); ++c) v[static_cast<std::size_t>(cols_[c])] = x[0][c];
    const auto model = base_.with_values(v);
    Eigen::VectorXd res;
    Eigen::MatrixXd jac;
    try {
      cal::linearise(*model, std::span<const Measurement>(&m_, 1), cols_, res, jac);
    } catch (const postproc::Error&) {
      return false;  // a probe step outside the model's reach
    }
    for (Eigen::Index i = 0; i < res.size(); ++i) residuals[i] = res[i];
    if (jacobians != nullptr && jacobians[0] != nullptr)
      for (Eigen::Index i = 0; i < jac.rows(); ++i)
        for (Eigen::Index c = 0; c < jac.cols(); ++c) jacobians[0][i * jac.cols() + c] = jac(i, c);
    return true;
  }

 private:
  const kin::Model& base_;
  Measurement m_;
  std::vector<int> cols_;
};

void gradient_check(const kin::Model& model, const Measurement& m, const std::vector<int>& cols, double tolerance) {
  LinearisedCost cost(model, m, cols);
  ceres::NumericDiffOptions nd;
  nd.relative_step_size = 1e-6;
  // GradientChecker differentiates by Ridders' method; its default first step (1e-2 of the value,
  // or absolute near 0) would tilt a guide by 0.3 rad.
  nd.ridders_relative_initial_step_size = 1e-5;
  const std::vector<const ceres::Manifold*>* no_manifolds = nullptr;
  ceres::GradientChecker checker(&cost, no_manifolds, nd);
  std::vector<double> x;
  for (int c : cols) x.push_back(model.values()[static_cast<std::size_t>(c)]);
  const double* params[] = {x.data()};
  ceres::GradientChecker::ProbeResults results;
  EXPECT_TRUE(checker.Probe(params, tolerance, &results)) << results.error_log;
}

TEST(GradientChecker, PrsHybridAnalyticIdentificationJacobian) {
  const auto nominal = kin::make_document001_machine();
  const auto truth = nominal->with_errors(kin::document001_table1_errors());
  const auto data = cal::doc001::simulate(*nominal, *truth, cal::doc001::pose_set(), 1, true, 0, 0);
  std::vector<int> cols;
  for (int k = 0; k < kin::PrsHybrid::kErrorCount; ++k) cols.push_back(k);
  for (std::size_t i : {0u, 5u, 13u, 26u}) {
    gradient_check(*truth, data[i], cols, 1e-5);
    Measurement five = data[i];
    five.has_torsion = false;
    gradient_check(*truth, five, cols, 1e-5);
  }
}

TEST(GradientChecker, HexapodStrutsAnalyticIdentificationJacobian) {
  const auto mach = load("machines/hexapod_doc003.toml");
  const kin::Model& model = *mach.actual;
  std::vector<int> cols(static_cast<std::size_t>(kin::kHexapodParameters));
  for (int k = 0; k < kin::kHexapodParameters; ++k) cols[static_cast<std::size_t>(k)] = k;
  kin::JointVector q = kin::JointVector::Zero(6);
  for (int i = 0; i < 3; ++i) {
    q << 10.0 * i, -20, 30, 5.0 * i, 0, -15;
    Measurement m;
    m.kind = MeasurementKind::struts;
    ASSERT_TRUE(model.forward(q, m.measured).ok());
    m.q = q;
    gradient_check(model, m, cols, 1e-6);
  }
}

TEST(GradientChecker, SerialChainDifferences) {
  // Serial parameters are differenced (steps 1e-5 mm / 1e-7 rad): a check of how the residual rows
  // are composed, with a tolerance for differencing noise (~1e-9 abs) on near-zero entries.
  const auto mach = load("machines/trunnion_ac_fanuc.toml");
  const kin::Model& model = *mach.actual;
  std::vector<int> cols;
  for (std::size_t k = 0; k < model.parameters().size(); ++k)
    if (model.parameters()[k].error) cols.push_back(static_cast<int>(k));
  for (const auto& m : poses(model, random_joints(model, 3, 11), 0, 0, 1)) gradient_check(model, m, cols, 1e-3);
}

// ------------------------------------------------------------------------------------------
// Identification against ground truth

/// |identified − truth| ≤ k·σ for every identified parameter; returns the largest ratio.
double worst_sigma_ratio(const kin::Model& truth, const cal::IdentifyResult& r) {
  double worst = 0;
  for (int k : r.identified) {
    const auto i = static_cast<std::size_t>(k);
    worst = std::max(worst, std::abs(r.values[i] - truth.values()[i]) / r.stddev[i]);
  }
  return worst;
}

TEST(Identify, SerialTrunnionFromPosesWithinThreeSigma) {
  // B/C trunnion sample: its 15 geometric errors from 40 6-DoF poses with ±1 µm / ±0.0003°
  // noise, starting from zero errors (the X/Y/Z error-motion tables are known data).
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const kin::Model& truth = *mach.actual;
  const auto start = zero_errors(truth);
  const auto data = poses(truth, random_joints(truth, 40, 21), 0.001, 0.0003, 22);
  const auto r = cal::identify(*start, data);
  ASSERT_TRUE(r.usable) << r.message;
  for (const auto& c : r.start.combinations) std::printf("  null: %s\n", c.c_str());
  EXPECT_GE(r.identified.size(), 12u);
  const double worst = worst_sigma_ratio(truth, r);
  std::printf("serial: %zu identified, %zu held, rank %d, condition %.3g, worst |error|/σ %.2f, σ %.5f mm\n",
              r.identified.size(), r.held.size(), r.start.rank, r.start.condition, worst, r.sigma);
  EXPECT_LE(worst, 3.0);
  // The identified model reproduces the measurements to the noise level.
  const auto solved = start->with_values(r.values);
  for (const auto& m : data) {
    const auto e = cal::measurement_error(*solved, m);
    EXPECT_LT(e.position_mm, 0.003) << m.label;
    EXPECT_LT(e.angle_deg, 0.001) << m.label;
  }
}

TEST(Identify, HexapodFromStrutReadingsWithinThreeSigma) {
  // Document 003: the 42 parameters from strut coordinates recorded at 40 known poses, noise
  // ±0.5 µm per strut reading. Start: the design values.
  const auto mach = load("machines/hexapod_doc003.toml");
  const kin::Model& truth = *mach.actual;
  const auto start = mach.nominal;
  const std::vector<Measurement> data = pptest::hexapod_strut_readings(truth, *start, 40);
  ASSERT_EQ(data.size(), 40u);
  const auto r = cal::identify(*start, data);
  ASSERT_TRUE(r.usable) << r.message;
  for (const auto& c : r.start.combinations) std::printf("  null: %s\n", c.c_str());
  const double worst = worst_sigma_ratio(truth, r);
  std::printf("hexapod: %zu identified, %zu held, rank %d of %d, condition %.3g, worst |error|/σ %.2f, σ %.6f mm, %d it, %.3f s\n",
              r.identified.size(), r.held.size(), r.start.rank, r.start.parameters, r.start.condition, worst, r.sigma,
              r.iterations, r.seconds);
  EXPECT_LE(worst, 3.0);
  // The strut residuals after are at the noise level.
  const auto solved = start->with_values(r.values);
  for (const auto& m : data) EXPECT_LT(cal::measurement_error(*solved, m).position_mm, 0.0015) << m.label;
}

TEST(Identify, ValidationMeasurementsAreNotFitted) {
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const kin::Model& truth = *mach.actual;
  const auto start = zero_errors(truth);
  auto data = poses(truth, random_joints(truth, 30, 41), 0.001, 0.0003, 42);
  for (std::size_t i = 0; i < data.size(); i += 3) data[i].validate = true;
  const auto r = cal::identify(*start, data);
  // A wildly wrong held-out measurement changes nothing.
  auto spoiled = data;
  spoiled[0].measured.p.x() += 5;
  const auto r2 = cal::identify(*start, spoiled);
  EXPECT_EQ(r.values, r2.values);
  cal::CalibrationRun run;
  const auto solved = start->with_values(r.values);
  run.start = start.get();
  run.solved = solved.get();
  run.data = data;
  run.result = r;
  const auto c = cal::compare(run);
  EXPECT_EQ(c.validation.count, 10u);
  EXPECT_EQ(c.fit.count, 20u);
  EXPECT_LT(c.validation.max_position_after_mm, 0.1 * c.validation.max_position_before_mm);
}

TEST(Identify, RobustLossResistsAnOutlier) {
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const kin::Model& truth = *mach.actual;
  const auto start = zero_errors(truth);
  auto data = poses(truth, random_joints(truth, 40, 51), 0.001, 0.0003, 52);
  data[7].measured.p += Eigen::Vector3d(0.3, -0.2, 0.25);  // a mis-read sphere
  cal::IdentifyOptions plain, robust;
  robust.loss = cal::Loss::cauchy;
  robust.loss_scale = 0.003;
  const auto rp = cal::identify(*start, data, plain);
  const auto rr = cal::identify(*start, data, robust);
  auto worst_error = [&](const cal::IdentifyResult& r) {
    double w = 0;
    for (int k : r.identified) w = std::max(w, std::abs(r.values[static_cast<std::size_t>(k)] - truth.values()[static_cast<std::size_t>(k)]) /
                                                   (truth.parameters()[static_cast<std::size_t>(k)].unit == "rad" ? 1e-3 : 1.0));
    return w;
  };
  EXPECT_LT(worst_error(rr), 0.3 * worst_error(rp));
}

TEST(Identify, FixedAndBoundedParameters) {
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const kin::Model& truth = *mach.actual;
  const auto start = zero_errors(truth);
  const auto data = poses(truth, random_joints(truth, 30, 61), 0.001, 0.0003, 62);
  cal::IdentifyOptions opt;
  const int ex0c = truth.parameter_index("EX0C");
  const int ey0c = truth.parameter_index("EY0C");
  ASSERT_GE(ex0c, 0);
  opt.fixed = {ex0c};
  opt.bounds.push_back({ey0c, {-0.001, 0.001}});
  const auto r = cal::identify(*start, data, opt);
  EXPECT_EQ(r.values[static_cast<std::size_t>(ex0c)], start->values()[static_cast<std::size_t>(ex0c)]);
  EXPECT_LE(std::abs(r.values[static_cast<std::size_t>(ey0c)]), 0.001 + 1e-12);
  EXPECT_TRUE(std::isnan(r.stddev[static_cast<std::size_t>(ex0c)]));
}

TEST(Identify, AnalyseNamesEveryNullDirection) {
  // Two rows, four parameters: p0 and p1 enter only as p0 + p1, p3 not at all. Rank 2; one
  // combination (+1 p0, −1 p1) and p3 unobserved, even with fewer rows than columns.
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const kin::Model& m = *mach.actual;
  Eigen::MatrixXd j(2, 4);
  j << 1, 1, 0, 0,  //
      0, 0, 2, 0;
  const std::vector<int> cols{0, 1, 2, 3};
  const cal::Identifiability a = cal::analyse(j, cols, m);
  EXPECT_EQ(a.rank, 2);
  ASSERT_EQ(a.combinations.size(), 1u);
  const std::string& c = a.combinations.front();
  EXPECT_NE(c.find(m.parameters()[0].name), std::string::npos) << c;
  EXPECT_NE(c.find(m.parameters()[1].name), std::string::npos) << c;
  EXPECT_NE(c.find("-1"), std::string::npos) << c;
  EXPECT_EQ(a.unobserved, std::vector<int>{3});
  ASSERT_EQ(a.dependent.size(), 2u);  // one of p0/p1, and p3
  EXPECT_TRUE(a.dependent[0] == 0 || a.dependent[0] == 1);
  EXPECT_EQ(a.dependent[1], 3);
  EXPECT_NEAR(a.condition, std::sqrt(2.0), 1e-12);  // column-scaled J = [[1, 1, 0], [0, 0, 1]]: σ = √2, 1
}

TEST(Identify, UnobservedParametersAreHeldAndNamed) {
  // Directions alone cannot see position errors: every mm parameter is unobserved, held at its
  // start value and never returned as an estimate.
  const auto mach = load("machines/trunnion_bc_fanuc.toml");
  const kin::Model& truth = *mach.actual;
  const auto start = zero_errors(truth);
  auto data = poses(truth, random_joints(truth, 30, 71), 0, 0.0003, 72);
  for (auto& m : data) m.kind = MeasurementKind::direction;
  const auto r = cal::identify(*start, data);
  for (std::size_t k = 0; k < truth.parameters().size(); ++k) {
    if (!truth.parameters()[k].error || truth.parameters()[k].unit != "mm") continue;
    EXPECT_NE(std::find(r.held.begin(), r.held.end(), static_cast<int>(k)), r.held.end()) << truth.parameters()[k].name;
    EXPECT_EQ(r.values[k], start->values()[k]);
  }
  EXPECT_FALSE(r.start.unobserved.empty());
}

}  // namespace

namespace {

TEST(GradientChecker, SerialIdentificationJacobianMatchesDifferences) {
  // The analytic d(pose)/d(parameters) of serial chains against central differences of the
  // model, on the samples (the lathe's Z axis carries error-motion tables) with their errors and
  // with every error parameter set to a few µm / arcsec / µm/m (tilts and squareness included).
  for (const char* name : {"machines/trunnion_bc_fanuc.toml", "machines/trunnion_ac_fanuc.toml",
                           "machines/lathe_xzbc_doc004.toml", "machines/trunnion_bc_heidenhain.toml"}) {
    const auto mach = load(name);
    const auto* serial = dynamic_cast<const kin::SerialModel*>(mach.actual.get());
    ASSERT_NE(serial, nullptr) << name;
    std::mt19937 rng(3);
    std::vector<double> v = serial->values();
    for (std::size_t k = 0; k < v.size(); ++k) {
      const auto& p = serial->parameters()[k];
      if (!p.error) continue;
      const double scale = p.unit == "rad" ? 3e-5 : p.unit == "ratio" ? 2e-5 : 0.01;
      v[k] += scale * std::uniform_real_distribution<double>(-1, 1)(rng);
    }
    const auto model = std::dynamic_pointer_cast<const kin::SerialModel>(serial->with_values(v));
    ASSERT_TRUE(model);
    for (const auto& q : random_joints(*model, 8, 17)) {
      const Eigen::Matrix<double, 6, Eigen::Dynamic> ja = model->identification_jacobian(q);
      for (std::size_t k = 0; k < v.size(); ++k) {
        const auto& p = model->parameters()[k];
        const double h = p.unit == "mm" ? 1e-4 : 1e-7;
        std::vector<double> a = v, b = v;
        a[k] += h;
        b[k] -= h;
        kin::Pose pa, pb;
        ASSERT_TRUE(model->with_values(a)->forward(q, pa).ok());
        ASSERT_TRUE(model->with_values(b)->forward(q, pb).ok());
        Eigen::Matrix<double, 6, 1> fd;
        fd.head<3>() = (pa.p - pb.p) / (2 * h);
        fd.tail<3>() = kin::rotation_difference(pa.r, pb.r) / (2 * h);
        const double tol = 1e-6 * std::max(1.0, fd.norm());
        EXPECT_LT((ja.col(static_cast<Eigen::Index>(k)) - fd).norm(), tol)
            << name << " " << p.name << " analytic " << ja.col(static_cast<Eigen::Index>(k)).transpose()
            << " differences " << fd.transpose();
      }
    }
  }
}

}  // namespace
