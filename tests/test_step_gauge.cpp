// The 3-D step gauge of document 002: simulated readings of a known error field come back as that
// field (exactly without noise, within the noise bound with it), tilt removal, chains, grid checks,
// located diagnostics for malformed files, the TOML round trip and the sample files.
#include <gtest/gtest.h>

#include <filesystem>
#include <iostream>
#include <fstream>
#include <sstream>

#include <fmt/format.h>

#include "postproc/calibration/step_gauge.hpp"
#include "postproc/machine/machine.hpp"

namespace {

namespace cal = postproc::cal;
namespace gc = postproc::gcode;
namespace kin = postproc::kin;
using Eigen::Vector2d;
using Eigen::Vector3d;

const std::string kSamples = std::string(POSTPROC_SOURCE_DIR) + "/samples/";

/// A smooth field with linear, quadratic and cross terms, µm-sized (mm).
Vector3d field(const Vector3d& p) {
  const Vector3d q = p / 100.0;
  return 1e-3 * Vector3d(2 + 3 * q.x() - q.y() + 0.5 * q.x() * q.z(), -1 + 2 * q.y() + 0.8 * q.x() * q.x() - q.z(),
                         4 + q.x() * q.y() - 1.5 * q.z() + 0.3 * q.y() * q.y());
}

/// Plates of 4 × 3 pyramids at z = -250, -100, 50, each chained to the one below through a vertical
/// "column" gauge whose pyramids sit at the plates' reference positions.
std::vector<cal::GaugeLayout> layouts(const Vector2d& tilt = Vector2d::Zero(), int levels = 3) {
  std::vector<cal::GaugeLayout> g;
  const double z[3] = {-250, -100, 50};
  for (int k = 0; k < levels; ++k) {
    g.push_back(cal::plate_layout("plate" + std::to_string(k), Vector3d(-10, -10, z[k]), Vector2d(110, 110), 4, 3,
                                  static_cast<std::uint64_t>(7 + k)));
    g.back().tilt = tilt * (k + 1);
    if (k > 0) g.back().chain = "1 = column:" + std::to_string(k + 1);
  }
  cal::GaugeLayout column = cal::plate_layout("column", Vector3d::Zero(), Vector2d(1, 1), 1, 1, 3);
  column.pyramids.clear();
  for (int k = 0; k < levels; ++k) {
    cal::PyramidLayout p = g[0].pyramids[0];
    p.id = std::to_string(k + 1);
    p.position = Vector3d(-10, -10, z[k]);
    column.pyramids.push_back(p);
  }
  column.chain = "1 = plate0:1";
  column.edges = false;
  g.push_back(column);
  return g;
}

struct Built {
  gc::DiagnosticSink sink;
  std::optional<kin::VolumetricMap> map;
  cal::StepGaugeReport report;
};

/// Simulates, reads back every file from text, builds.
std::unique_ptr<Built> run(const std::vector<cal::GaugeLayout>& l, const cal::StepGaugeSimulateOptions& o,
                           const std::function<Vector3d(const Vector3d&)>& f = field) {
  auto b = std::make_unique<Built>();
  cal::StepGaugeData data;
  const auto files = cal::simulate_step_gauge(f, l, o);
  for (std::size_t i = 0; i < files.size(); ++i) {
    EXPECT_TRUE(cal::add_step_gauge_text(l[i].name + ".csv", files[i].gauge_csv, data, b->sink));
    if (!files[i].edge_csv.empty()) {
      EXPECT_TRUE(cal::add_step_gauge_text(l[i].name + "_edges.csv", files[i].edge_csv, data, b->sink));
    }
  }
  b->map = cal::build_volumetric_map(data, {}, b->sink, &b->report);
  for (const auto& d : b->sink.stored()) ADD_FAILURE() << gc::format(d);
  return b;
}

/// Max |E_map − (E_true − E_true(reference))| over the nodes, mm.
double worst(const kin::VolumetricMap& m, const std::function<Vector3d(const Vector3d&)>& f = field) {
  const Vector3d e0 = f(m.origin());
  double w = 0;
  for (int k = 0; k < m.counts()[2]; ++k)
    for (int j = 0; j < m.counts()[1]; ++j)
      for (int i = 0; i < m.counts()[0]; ++i) {
        const Vector3d p = m.origin() + m.spacing().cwiseProduct(Vector3d(i, j, k));
        w = std::max(w, (m.node(i, j, k) - (f(p) - e0)).cwiseAbs().maxCoeff());
      }
  return w;
}

TEST(StepGauge, ExactWithoutNoise) {
  const auto b = run(layouts(), {});
  ASSERT_TRUE(b->map);
  EXPECT_EQ(b->map->counts(), Eigen::Vector3i(4, 3, 3));
  EXPECT_TRUE(b->map->origin().isApprox(Vector3d(-10, -10, -250)));
  EXPECT_TRUE(b->map->spacing().isApprox(Vector3d(110, 110, 150)));
  EXPECT_LT(worst(*b->map), 1e-9);
  EXPECT_EQ(b->report.points.size(), 3u * 12 + 3);
  EXPECT_EQ(b->report.tilts.size(), 4u);
  double max_error = 0;
  for (const auto& p : b->report.points) max_error = std::max(max_error, (field(p.position) - field(b->map->origin())).norm());
  EXPECT_NEAR(b->report.max_error, max_error, 1e-12);
}

TEST(StepGauge, NoiseBound) {
  // ±0.1 µm per reading; |T⁻¹|∞ ≈ 1.3 here, chained over two links (column, plate): ≲ 3 · 1.3 · 2 · 0.1 µm.
  cal::StepGaugeSimulateOptions o;
  o.noise_mm = 1e-4;
  o.seed = 99;
  const auto b = run(layouts(Vector2d(20e-6, -15e-6)), o);
  ASSERT_TRUE(b->map);
  const double w = worst(*b->map);
  EXPECT_LT(w, 1.0e-3);
  EXPECT_GT(w, 1e-6);  // the noise is there
  for (const auto& p : b->report.points) EXPECT_LT(p.noise_gain, 2.5);
}

TEST(StepGauge, TiltIsRemoved) {
  const Vector2d tilt(50e-6, -30e-6);  // 50 µm/m, −30 µm/m
  const auto b = run(layouts(tilt), {});
  ASSERT_TRUE(b->map);
  EXPECT_LT(worst(*b->map), 1e-9);
  EXPECT_TRUE(b->report.tilts[0].measured);
  EXPECT_NEAR(b->report.tilts[0].theta.x(), 50e-6, 1e-12);
  EXPECT_NEAR(b->report.tilts[2].theta.y(), -90e-6, 1e-12);
  EXPECT_FALSE(b->report.tilts[3].measured);  // the column has no edge file

  // Without the edge files, the tilt stays in the map: Ez of plate 0 is off by θx·dx + θy·dy.
  cal::StepGaugeData data;
  gc::DiagnosticSink sink;
  const auto l = layouts(tilt);
  const auto files = cal::simulate_step_gauge(field, l, {});
  for (std::size_t i = 0; i < files.size(); ++i) ASSERT_TRUE(cal::add_step_gauge_text("g", files[i].gauge_csv, data, sink));
  const auto m = cal::build_volumetric_map(data, {}, sink);
  ASSERT_TRUE(m);
  const Vector3d p(320, 210, -250);
  const double dz = m->node(3, 2, 0).z() - (field(p) - field(m->origin())).z();
  EXPECT_NEAR(dz, -(tilt.x() * 330 + tilt.y() * 220), 1e-9);
}

TEST(StepGauge, TwoGaugesChainedDirectly) {
  // "low": 4 × 2 pyramids at z = 0 (ids 1…4 at y = -10, 5…8 at y = 100). "high": a two-level gauge
  // whose reference pyramid 1 is read where low:5 was (x = -10, y = 100, z = 0), and 8 pyramids at z = 80.
  std::vector<cal::GaugeLayout> l{cal::plate_layout("low", Vector3d(-10, -10, 0), Vector2d(110, 110), 4, 2, 1),
                                  cal::plate_layout("high", Vector3d(-10, -10, 80), Vector2d(110, 110), 4, 2, 2)};
  cal::PyramidLayout link = l[1].pyramids.front();
  link.position = Vector3d(-10, 100, 0);
  for (auto& p : l[1].pyramids) p.id = std::to_string(std::stoi(p.id) + 1);
  link.id = "1";
  l[1].pyramids.insert(l[1].pyramids.begin(), link);
  l[1].reference = "1";
  l[1].chain = "1 = low:5";
  l[1].tilt = Vector2d(10e-6, 20e-6);
  const auto b = run(l, {});
  ASSERT_TRUE(b->map);
  EXPECT_EQ(b->map->counts(), Eigen::Vector3i(4, 2, 2));
  EXPECT_LT(worst(*b->map), 1e-9);
  EXPECT_EQ(b->report.points.size(), 17u);
}

TEST(StepGauge, ThreeLevelChainThroughColumn) {
  // Root error known from elsewhere: the map is then absolute.
  auto l = layouts();
  l[0].write_reference_error = true;
  const auto b = run(l, {});
  ASSERT_TRUE(b->map);
  EXPECT_LT((b->map->node(2, 1, 2) - field(Vector3d(210, 100, 50))).norm(), 1e-9);
}

// --- refusals ---------------------------------------------------------------------------------

struct Refusal {
  gc::DiagnosticSink sink;
  bool read_ok = true;
  std::optional<kin::VolumetricMap> map;
  [[nodiscard]] const gc::Diagnostic& first() const { return sink.stored().front(); }
};

/// Reads the given (file name, text) pairs and builds when all read.
std::unique_ptr<Refusal> refuse(const std::vector<std::pair<std::string, std::string>>& files) {
  auto r = std::make_unique<Refusal>();
  cal::StepGaugeData data;
  for (const auto& [name, text] : files) r->read_ok = cal::add_step_gauge_text(name, text, data, r->sink) && r->read_ok;
  if (r->read_ok) r->map = cal::build_volumetric_map(data, {}, r->sink);
  EXPECT_FALSE(r->map);
  EXPECT_FALSE(r->sink.stored().empty());
  return r;
}

std::vector<std::pair<std::string, std::string>> simulated(const std::vector<cal::GaugeLayout>& l) {
  std::vector<std::pair<std::string, std::string>> out;
  const auto files = cal::simulate_step_gauge(field, l, {});
  for (std::size_t i = 0; i < files.size(); ++i) {
    out.emplace_back(l[i].name + ".csv", files[i].gauge_csv);
    if (!files[i].edge_csv.empty()) out.emplace_back(l[i].name + "_edges.csv", files[i].edge_csv);
  }
  return out;
}

const std::string kHead = "# kind: step-gauge\n# gauge: g\npyramid,x_mm,y_mm,z_mm,ax,ay,bx,by,cx,cy,dA_um,dB_um,dC_um\n";
const std::string kRow1 = "1,0,0,0,0,-0.8,0.7,0.4,-0.7,0.4,0,0,0\n";

void expect_at(const Refusal& r, std::string_view code, std::uint64_t line, std::uint32_t column) {
  ASSERT_FALSE(r.sink.stored().empty());
  const auto& d = r.first();
  EXPECT_EQ(d.code, code) << gc::format(d);
  EXPECT_EQ(d.where.line, line) << gc::format(d);
  EXPECT_EQ(d.where.column, column) << gc::format(d);
}

TEST(StepGaugeRefuse, MissingColumn) {
  auto r = refuse({{"g.csv", "# kind: step-gauge\n# gauge: g\npyramid,x_mm,y_mm,z_mm,ax,ay,bx,by,cx,cy,dA_um,dB_um\n"}});
  expect_at(*r, "PP-C002", 3, 1);
  EXPECT_NE(r->first().message.find("dC"), std::string::npos);
}

TEST(StepGaugeRefuse, BadNumber) {
  auto r = refuse({{"g.csv", kHead + kRow1 + "2,110,0,0,0,-0.8,0.7,0.4,-0.7,0.4,1.5,x2,0\n"}});
  expect_at(*r, "PP-C003", 5, 39);
}

TEST(StepGaugeRefuse, WrongUnit) {
  auto r = refuse({{"g.csv", "# kind: step-gauge\n# gauge: g\npyramid,x_mm,y_mm,z_mm,ax,ay,bx,by,cx,cy,dA_deg,dB_um,dC_um\n" + kRow1}});
  expect_at(*r, "PP-C004", 3, 42);
  auto r2 = refuse({{"g.csv", "# kind: step-gauge\n# gauge: g\npyramid,x_mm,y_mm,z_mm,ax_mm,ay,bx,by,cx,cy,dA_um,dB_um,dC_um\n" + kRow1}});
  expect_at(*r2, "PP-C004", 3, 24);
}

TEST(StepGaugeRefuse, SingularT) {
  auto r = refuse({{"g.csv", kHead + kRow1 + "  7,110,0,0,0.1,0.1,0.2,0.2,0.3,0.3,0,0,0\n"}});
  expect_at(*r, "PP-C005", 5, 3);
  EXPECT_NE(r->first().message.find("'7'"), std::string::npos);
}

TEST(StepGaugeRefuse, UnknownChainGauge) {
  auto l = layouts();
  l[1].chain = "1 = colum:2";
  auto r = refuse(simulated(l));
  const auto& d = r->first();
  EXPECT_EQ(d.code, "PP-C006");
  EXPECT_EQ(d.file, "plate1.csv");
  EXPECT_EQ(d.where.line, 4u);  // kind, gauge, reference, chain
  EXPECT_EQ(d.where.column, 10u);
  EXPECT_NE(d.message.find("colum"), std::string::npos);
}

TEST(StepGaugeRefuse, ChainCycle) {
  auto l = layouts();
  l[3].chain = "1 = plate1:1";  // column → plate1 → column
  auto r = refuse(simulated(l));
  EXPECT_EQ(r->first().code, "PP-C006");
  EXPECT_NE(r->first().message.find("cycle"), std::string::npos) << gc::format(r->first());
  EXPECT_EQ(r->first().where.line, 4u);
}

TEST(StepGaugeRefuse, NonRegularGrid) {
  auto l = layouts();
  l[2].pyramids[5].position.x() += 0.01;  // 10 µm off its node
  auto r = refuse(simulated(l));
  EXPECT_EQ(r->first().code, "PP-C006");
  EXPECT_EQ(r->first().file, "plate2.csv");
  EXPECT_EQ(r->first().where.line, 5u + 6);  // 4 header comments + the column header, 6th row
  EXPECT_NE(r->first().message.find("off the regular grid"), std::string::npos);

  auto missing = layouts();
  missing[1].pyramids.pop_back();
  auto r2 = refuse(simulated(missing));
  EXPECT_NE(r2->first().message.find("has no pyramid"), std::string::npos) << gc::format(r2->first());

  auto twice = layouts();
  twice[1].pyramids[3].position = twice[1].pyramids[2].position;
  auto r3 = refuse(simulated(twice));
  EXPECT_NE(r3->first().message.find("already measured"), std::string::npos) << gc::format(r3->first());

  auto flat = layouts(Vector2d::Zero(), 1);
  auto r4 = refuse(simulated(flat));
  EXPECT_NE(r4->first().message.find("two or more node planes along z"), std::string::npos);
}

TEST(StepGaugeRefuse, TwoRootsAndMisc) {
  auto l = layouts();
  l[2].chain.reset();
  auto r = refuse(simulated(l));
  EXPECT_NE(r->first().message.find("root already"), std::string::npos) << gc::format(r->first());

  auto r2 = refuse({{"e.csv", "# kind: step-gauge-edge\n# gauge: g\nedge,s_mm,reading_um\nx,0,1\nx,10,2\nz,0,1\n"}});
  expect_at(*r2, "PP-C005", 6, 1);
  auto r3 = refuse({{"e.csv", "# kind: step-gauge-edge\n# gauge: g\nedge,s_mm,reading_um\nx,0,1\nx,10,2\ny,0,1\n"}});
  EXPECT_EQ(r3->first().code, "PP-C005");
  auto r4 = refuse({{"g.csv", "# kind: step-gauge\n# chain: 1 = a\n" + kHead.substr(kHead.find("pyramid")) + kRow1}});
  expect_at(*r4, "PP-C002", 3, 1);  // no gauge name
  auto r5 = refuse({{"g.csv", "# kind: step-gauge\n# gauge: g\n# chain: 1 = a\n" + kHead.substr(kHead.find("pyramid")) + kRow1}});
  expect_at(*r5, "PP-C001", 3, 10);
  auto r6 = refuse({{"g.csv", kHead + kRow1 + kRow1}});
  expect_at(*r6, "PP-C006", 5, 1);
  auto r7 = refuse({{"g.csv", "# kind: poses\n" + kHead.substr(kHead.find("pyramid")) + kRow1}});
  expect_at(*r7, "PP-C006", 1, 9);
  auto r8 = refuse({{"g.csv", kHead.substr(0, kHead.size() - 1) + ",extra_mm\n" + kRow1.substr(0, kRow1.size() - 1) + ",1\n"}});
  expect_at(*r8, "PP-C006", 3, 60);
}

// --- TOML and samples -------------------------------------------------------------------------

std::string slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The sample machine with its [volumetric_map] section replaced by `section`.
std::string with_map(const std::string& section) {
  std::string m = slurp(kSamples + "machines/mill3_stepgauge_map.toml");
  const auto a = m.find("[volumetric_map]");
  const auto b = m.find("[axes.X]");
  return m.substr(0, a) + section + "\n" + m.substr(b);
}

const kin::VolumetricMap& map_of(const postproc::machine::Machine& m) {
  return dynamic_cast<const kin::VolumetricModel&>(*m.actual).map();
}

TEST(StepGaugeToml, RoundTrip) {
  auto b = run(layouts(), {});
  ASSERT_TRUE(b->map);
  const kin::VolumetricMap smooth(b->map->origin(), b->map->spacing(), b->map->counts(), b->map->values(),
                                  kin::VolumetricMap::Interpolation::smooth, kin::VolumetricMap::Outside::clamp);
  gc::DiagnosticSink sink;
  const auto m = postproc::machine::parse_machine("m.toml", with_map(cal::volumetric_map_toml(smooth)), sink);
  for (const auto& d : sink.stored()) ADD_FAILURE() << gc::format(d);
  ASSERT_TRUE(m);
  const auto& back = map_of(*m);
  EXPECT_EQ(back.counts(), smooth.counts());
  EXPECT_TRUE(back.origin().isApprox(smooth.origin()));
  EXPECT_TRUE(back.spacing().isApprox(smooth.spacing()));
  EXPECT_EQ(back.interpolation(), smooth.interpolation());
  EXPECT_EQ(back.outside(), smooth.outside());
  for (std::size_t n = 0; n < back.values().size(); ++n)
    EXPECT_LT((back.values()[n] - smooth.values()[n]).cwiseAbs().maxCoeff(), 0.5e-7 + 1e-12);
}

TEST(StepGaugeSamples, BuildTheSampleMachinesMap) {
  std::vector<std::string> paths;
  for (const auto& e : std::filesystem::directory_iterator(kSamples + "measurements"))
    if (e.path().filename().string().rfind("stepgauge_", 0) == 0) paths.push_back(e.path().string());
  std::sort(paths.begin(), paths.end());
  ASSERT_GE(paths.size(), 4u);
  gc::DiagnosticSink sink;
  const auto data = cal::read_step_gauge(paths, sink);
  for (const auto& d : sink.stored()) ADD_FAILURE() << gc::format(d);
  ASSERT_TRUE(data);
  const auto map = cal::build_volumetric_map(*data, {}, sink);
  for (const auto& d : sink.stored()) ADD_FAILURE() << gc::format(d);
  ASSERT_TRUE(map);
  gc::DiagnosticSink msink;
  const auto machine = postproc::machine::load_machine(kSamples + "machines/mill3_stepgauge_map.toml", msink);
  ASSERT_TRUE(machine);
  const auto& want = map_of(*machine);
  ASSERT_EQ(map->counts(), want.counts());
  EXPECT_TRUE(map->origin().isApprox(want.origin()));
  EXPECT_TRUE(map->spacing().isApprox(want.spacing()));
  double w = 0;
  for (std::size_t n = 0; n < want.values().size(); ++n)
    w = std::max(w, (map->values()[n] - want.values()[n]).cwiseAbs().maxCoeff());
  EXPECT_LT(w, 0.3e-3);  // the samples carry ±0.1 µm reading noise (0.15 µm found)
  std::cout << "samples vs the sample machine's map: max |ΔE| = " << w * 1000 << " µm\n";
}

/// Writes samples/measurements/stepgauge_*.csv: run with --gtest_also_run_disabled_tests
/// --gtest_filter=*Regenerate. The field is the sample machine's own map (so the samples build back
/// into it, up to the noise); the root gauge carries its reference pyramid's error from that map.
TEST(StepGaugeSamples, DISABLED_Regenerate) {
  gc::DiagnosticSink sink;
  const auto machine = postproc::machine::load_machine(kSamples + "machines/mill3_stepgauge_map.toml", sink);
  ASSERT_TRUE(machine);
  const kin::VolumetricMap& map = map_of(*machine);
  auto l = layouts();
  const char* names[4] = {"low", "mid", "high", "column"};
  const Vector2d tilts[3] = {{15e-6, -10e-6}, {-20e-6, 8e-6}, {5e-6, 25e-6}};
  for (std::size_t i = 0; i < 4; ++i) {
    l[i].name = names[i];
    if (i < 3) l[i].tilt = tilts[i];
  }
  l[0].write_reference_error = true;
  l[1].chain = "1 = column:2";
  l[2].chain = "1 = column:3";
  l[3].chain = "1 = low:1";
  std::filesystem::create_directories(kSamples + "measurements");
  for (std::size_t i = 0; i < 4; ++i) {
    cal::StepGaugeSimulateOptions o;
    o.noise_mm = 1e-4;
    o.seed = 2002 + i;
    o.decimals = 4;
    o.comment = fmt::format(
        "Sample for document 002 (3-D step gauge), made by cal::simulate_step_gauge (tests/test_step_gauge.cpp,\n"
        "StepGaugeSamples.DISABLED_Regenerate) from the [volumetric_map] of samples/machines/mill3_stepgauge_map.toml:\n"
        "gauge '{}', {}, uniform reading noise ±0.1 µm, seed {}.", l[i].name,
        l[i].edges ? fmt::format("plate tilt θx = {:g} µrad, θy = {:g} µrad", l[i].tilt.x() * 1e6, l[i].tilt.y() * 1e6)
                   : std::string("a vertical column gauge without edge scans"),
        o.seed);
    const auto f = cal::simulate_step_gauge([&](const Vector3d& p) { return *map.error(p); },
                                            std::span(&l[i], 1), o);
    std::ofstream(kSamples + "measurements/stepgauge_" + l[i].name + ".csv") << f[0].gauge_csv;
    if (!f[0].edge_csv.empty())
      std::ofstream(kSamples + "measurements/stepgauge_" + l[i].name + "_edges.csv") << f[0].edge_csv;
  }
}

}  // namespace

namespace {

TEST(StepGauge, GridLayoutsRebuildAMapExactly) {
  // calibrate simulate --kind step-gauge: the gauges grid_layouts() places over a map's grid give
  // that map back (no noise: to 1e-9 mm), tilts removed, the root's reference error carried.
  gc::DiagnosticSink sink;
  const auto machine = postproc::machine::load_machine(kSamples + "machines/mill3_stepgauge_map.toml", sink);
  ASSERT_TRUE(machine);
  const kin::VolumetricMap& map = map_of(*machine);
  const Vector2d tilts[] = {{15e-6, -10e-6}, {-20e-6, 8e-6}};
  const auto l = cal::grid_layouts(map.origin(), map.spacing(), map.counts(), tilts, 5);
  ASSERT_EQ(l.size(), static_cast<std::size_t>(map.counts().z() + 1));
  const auto files = cal::simulate_step_gauge([&](const Vector3d& p) { return *map.error(p); }, l, {});
  cal::StepGaugeData data;
  for (std::size_t i = 0; i < files.size(); ++i) {
    ASSERT_TRUE(cal::add_step_gauge_text(l[i].name + ".csv", files[i].gauge_csv, data, sink));
    if (!files[i].edge_csv.empty()) {
      ASSERT_TRUE(cal::add_step_gauge_text(l[i].name + "_edges.csv", files[i].edge_csv, data, sink));
    }
  }
  const auto built = cal::build_volumetric_map(data, {}, sink);
  ASSERT_TRUE(built) << (sink.stored().empty() ? "" : sink.stored().front().message);
  ASSERT_EQ(built->counts(), map.counts());
  for (int k = 0; k < map.counts().z(); ++k)
    for (int j = 0; j < map.counts().y(); ++j)
      for (int i = 0; i < map.counts().x(); ++i) EXPECT_LT((built->node(i, j, k) - map.node(i, j, k)).norm(), 1e-9);
}

}  // namespace
