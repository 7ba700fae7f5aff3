// Contour-error reports (issue 6): CSV, JSON and HTML of a hand-built path and prediction.
#include "postproc/contour/report.hpp"
#include "postproc/error.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

namespace pc = postproc::contour;
using nlohmann::json;

namespace {

constexpr double kArcsecPerRad = 180.0 / 3.14159265358979323846 * 3600.0;

/// Four points on a line along X, one run, two joints, no controller contexts.
pc::Path small_path() {
  pc::Path p;
  p.joints = 2;
  const std::vector<std::uint64_t> lines{10, 20, 30, 40};
  for (std::size_t i = 0; i < lines.size(); ++i) {
    pc::PathPoint pt;
    pt.q = postproc::kin::JointVector::Zero(2);
    pt.t = 0.5 * static_cast<double>(i);
    pt.line = lines[i];
    pt.run_start = i == 0;
    p.points.push_back(pt);
  }
  p.runs.push_back({0, 4});
  p.duration = 1.5;
  return p;
}

/// max / RMS / worst of `v` (p95: the largest value below the top 5 %), as reference.hpp's summarise.
pc::Summary summary(const std::vector<double>& v) {
  pc::Summary s;
  s.count = v.size();
  if (v.empty()) return s;
  double sum = 0;
  for (std::size_t i = 0; i < v.size(); ++i) {
    sum += v[i] * v[i];
    if (v[i] > s.max) {
      s.max = v[i];
      s.worst = i;
    }
  }
  s.rms = std::sqrt(sum / static_cast<double>(v.size()));
  std::vector<double> sorted = v;
  std::sort(sorted.begin(), sorted.end());
  s.p95 = sorted[static_cast<std::size_t>(0.95 * static_cast<double>(sorted.size() - 1))];
  return s;
}

/// tip errors (mm) and axis errors (rad) per point; the error vector along −Y, actual tip x = i.
pc::Prediction prediction(const std::vector<double>& tip_mm, const std::vector<double>& axis_rad) {
  pc::Prediction pr;
  for (std::size_t i = 0; i < tip_mm.size(); ++i) {
    pc::PointPrediction pp;
    pp.following = postproc::kin::JointVector::Zero(2);
    pp.following[0] = 0.01 * static_cast<double>(i);
    pp.following[1] = 0.002;
    pp.tip = Eigen::Vector3d(static_cast<double>(i), tip_mm[i], 5.0);
    pp.error = Eigen::Vector3d(0, -tip_mm[i], 0);
    pp.tip_mm = tip_mm[i];
    pp.axis_rad = axis_rad[i];
    pr.points.push_back(pp);
  }
  pr.tip = summary(tip_mm);
  pr.axis = summary(axis_rad);
  pr.max_following = {0.03, 0.002};
  return pr;
}

std::vector<std::string> lines_of(const std::string& s) {
  std::vector<std::string> out;
  std::istringstream in(s);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

std::vector<std::string> split(const std::string& s) {
  std::vector<std::string> out;
  std::string f;
  for (char c : s) {
    if (c == ',') {
      out.push_back(f);
      f.clear();
    } else {
      f += c;
    }
  }
  out.push_back(f);
  return out;
}

std::size_t count(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + 1)) ++n;
  return n;
}

struct Fixture {
  pc::Path path = small_path();
  // tip 1, 5, 3, 2 µm; axis 4, 1, 2, 8 arcsec
  pc::Prediction before = prediction({0.001, 0.005, 0.003, 0.002},
                                     {4 / kArcsecPerRad, 1 / kArcsecPerRad, 2 / kArcsecPerRad, 8 / kArcsecPerRad});
  pc::Prediction after = prediction({0.0002, 0.001, 0.0005, 0.0001},
                                    {1 / kArcsecPerRad, 0.5 / kArcsecPerRad, 0.5 / kArcsecPerRad, 2 / kArcsecPerRad});
  pc::ContourReport report() const {
    pc::ContourReport r;
    r.title = "predict a<b&c.nc";
    r.program = "a<b&c.nc";
    r.machine_file = "machines/m.toml";
    r.machine_sha256 = "abc123";
    r.tool_version = "0.6.0";
    r.path = &path;
    r.before = &before;
    r.fit_residual_mm = 2e-5;
    r.worst = 3;
    return r;
  }
};

}  // namespace

TEST(ContourReport, CsvHeaderRowsAndValues) {
  Fixture f;
  pc::ContourReport r = f.report();
  auto rows = lines_of(pc::report_csv(r));
  ASSERT_EQ(rows.size(), 5u);
  EXPECT_EQ(rows[0],
            "index,line,time_s,run,x_mm,y_mm,z_mm,following_j1_mm,following_j2_mm,tip_um,tip_x_um,tip_y_um,tip_z_um,"
            "axis_arcsec");
  auto row = split(rows[2]);  // point 1
  ASSERT_EQ(row.size(), 14u);
  EXPECT_EQ(row[0], "1");
  EXPECT_EQ(row[1], "20");
  EXPECT_DOUBLE_EQ(std::stod(row[2]), 0.5);
  EXPECT_EQ(row[3], "0");
  // intended tip = actual + error = (1, 0, 5)
  EXPECT_DOUBLE_EQ(std::stod(row[4]), 1.0);
  EXPECT_NEAR(std::stod(row[5]), 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(std::stod(row[6]), 5.0);
  EXPECT_NEAR(std::stod(row[7]), 0.01, 1e-9);
  EXPECT_NEAR(std::stod(row[9]), 5.0, 1e-6);    // µm
  EXPECT_NEAR(std::stod(row[11]), -5.0, 1e-6);  // y component, µm
  EXPECT_NEAR(std::stod(row[13]), 1.0, 1e-5);   // arcsec

  r.after = &f.after;
  rows = lines_of(pc::report_csv(r));
  ASSERT_EQ(rows.size(), 5u);
  const auto head = split(rows[0]);
  ASSERT_EQ(head.size(), 21u);
  EXPECT_EQ(head[14], "after_following_j1_mm");
  EXPECT_EQ(head[16], "after_tip_um");
  EXPECT_EQ(head[20], "after_axis_arcsec");
  row = split(rows[2]);
  ASSERT_EQ(row.size(), 21u);
  EXPECT_NEAR(std::stod(row[16]), 1.0, 1e-6);
  EXPECT_NEAR(std::stod(row[20]), 0.5, 1e-6);
}

TEST(ContourReport, JsonSummaryReductionAndWorst) {
  Fixture f;
  pc::ContourReport r = f.report();
  r.after = &f.after;
  pc::Precompensation comp;
  comp.iterations = 3;
  comp.converged = true;
  comp.history_mm = {0.002, 0.001};
  comp.history_rad = {1e-5, 5e-6};
  r.compensation = &comp;
  pc::Simulation sim;
  sim.tip.max = 0.004;
  sim.axis.max = 3 / kArcsecPerRad;
  sim.samples = 1500;
  sim.worst_tip_line = 30;
  sim.worst_axis_line = 40;
  sim.max_following = {0.025, 0.001};
  r.simulated_before = &sim;

  const json j = json::parse(pc::report_json(r));
  for (const char* key : {"tool", "program", "machine", "points", "runs", "duration_s", "fit_residual_um", "predicted",
                          "after", "reduction_percent", "iterations", "converged", "history_um", "history_arcsec",
                          "simulated_before", "worst", "worst_axis"})
    EXPECT_TRUE(j.contains(key)) << key;
  EXPECT_FALSE(j.contains("simulated_after"));
  EXPECT_EQ(j["program"], "a<b&c.nc");
  EXPECT_EQ(j["machine"]["sha256"], "abc123");
  EXPECT_EQ(j["points"], 4);
  EXPECT_EQ(j["runs"], 1);
  EXPECT_DOUBLE_EQ(j["duration_s"].get<double>(), 1.5);
  EXPECT_NEAR(j["fit_residual_um"].get<double>(), 0.02, 1e-12);
  EXPECT_NEAR(j["predicted"]["tip_um"]["max"].get<double>(), 5.0, 1e-9);
  EXPECT_NEAR(j["predicted"]["axis_arcsec"]["max"].get<double>(), 8.0, 1e-9);
  EXPECT_EQ(j["predicted"]["tip_um"]["worst_line"], 20);
  EXPECT_TRUE(j["predicted"]["tip_um"].contains("rms"));
  EXPECT_TRUE(j["predicted"]["tip_um"].contains("p95"));
  EXPECT_NEAR(j["predicted"]["max_following"]["j1"]["max"].get<double>(), 0.03, 1e-12);
  EXPECT_EQ(j["predicted"]["max_following"]["j2"]["unit"], "mm");
  EXPECT_NEAR(j["after"]["tip_um"]["max"].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(j["reduction_percent"]["tip"].get<double>(), 80.0, 1e-9);
  EXPECT_NEAR(j["reduction_percent"]["axis"].get<double>(), 75.0, 1e-9);
  EXPECT_EQ(j["iterations"], 3);
  EXPECT_EQ(j["converged"], true);
  ASSERT_EQ(j["history_um"].size(), 2u);
  EXPECT_NEAR(j["history_um"][1].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(j["history_arcsec"][0].get<double>(), 1e-5 * kArcsecPerRad, 1e-9);
  EXPECT_NEAR(j["simulated_before"]["tip_um"]["max"].get<double>(), 4.0, 1e-9);
  EXPECT_EQ(j["simulated_before"]["samples"], 1500);
  EXPECT_EQ(j["simulated_before"]["worst_tip_line"], 30);
  EXPECT_EQ(j["simulated_before"]["worst_axis_line"], 40);

  // tip 1, 5, 3, 2 µm at lines 10…40: the 3 worst are points 1, 2, 3.
  const json& w = j["worst"];
  ASSERT_EQ(w.size(), 3u);
  EXPECT_EQ(w[0]["point"], 1);
  EXPECT_EQ(w[0]["line"], 20);
  EXPECT_NEAR(w[0]["tip_um"].get<double>(), 5.0, 1e-9);
  EXPECT_NEAR(w[0]["axis_arcsec"].get<double>(), 1.0, 1e-9);
  EXPECT_EQ(w[1]["line"], 30);
  EXPECT_EQ(w[2]["line"], 40);
  EXPECT_GE(w[0]["tip_um"].get<double>(), w[1]["tip_um"].get<double>());
  EXPECT_GE(w[1]["tip_um"].get<double>(), w[2]["tip_um"].get<double>());
  // axis 4, 1, 2, 8 arcsec: points 3, 0, 2.
  const json& wa = j["worst_axis"];
  ASSERT_EQ(wa.size(), 3u);
  EXPECT_EQ(wa[0]["line"], 40);
  EXPECT_NEAR(wa[0]["axis_arcsec"].get<double>(), 8.0, 1e-9);
  EXPECT_EQ(wa[1]["line"], 10);
  EXPECT_EQ(wa[2]["line"], 30);
}

TEST(ContourReport, JsonWithoutOptionalsAndZeroBefore) {
  Fixture f;
  pc::ContourReport r = f.report();
  json j = json::parse(pc::report_json(r));
  for (const char* key : {"after", "reduction_percent", "iterations", "history_um", "simulated_before", "simulated_after"})
    EXPECT_FALSE(j.contains(key)) << key;

  // A program without error: no reduction to report.
  pc::Prediction zero = prediction({0, 0, 0, 0}, {0, 0, 0, 0});
  r.before = &zero;
  r.after = &zero;
  j = json::parse(pc::report_json(r));
  EXPECT_TRUE(j["reduction_percent"]["tip"].is_null());
  EXPECT_TRUE(j["reduction_percent"]["axis"].is_null());
}

TEST(ContourReport, HtmlSelfContainedAndEscaped) {
  Fixture f;
  pc::ContourReport r = f.report();
  r.after = &f.after;
  const std::string h = pc::report_html(r);
  EXPECT_EQ(h.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(h.find("<svg"), std::string::npos);
  EXPECT_EQ(count(h, "<svg"), count(h, "</svg>"));
  // The only URIs are the SVG namespace.
  const std::string ns = "http://www.w3.org/2000/svg";
  EXPECT_EQ(count(h, "http://"), count(h, ns));
  EXPECT_EQ(count(h, "https://"), 0u);
  EXPECT_EQ(h.find("<script"), std::string::npos);
  EXPECT_NE(h.find("a&lt;b&amp;c.nc"), std::string::npos);
  EXPECT_EQ(h.find("a<b&c"), std::string::npos);
  EXPECT_NE(h.find("µm"), std::string::npos);
  EXPECT_NE(h.find("arcsec"), std::string::npos);
  EXPECT_NE(h.find("after precompensation"), std::string::npos);  // legend
  EXPECT_NE(h.find("id=\"worst\""), std::string::npos);
  // Deterministic.
  EXPECT_EQ(h, pc::report_html(r));
  EXPECT_EQ(pc::report_json(r), pc::report_json(r));
  EXPECT_EQ(pc::report_csv(r), pc::report_csv(r));
}

TEST(ContourReport, EmptyPath) {
  pc::Path path;
  pc::Prediction pr;
  pc::ContourReport r;
  r.path = &path;
  r.before = &pr;
  EXPECT_EQ(lines_of(pc::report_csv(r)).size(), 1u);
  const json j = json::parse(pc::report_json(r));
  EXPECT_EQ(j["points"], 0);
  EXPECT_TRUE(j["worst"].empty());
  EXPECT_EQ(pc::report_html(r).rfind("<!DOCTYPE html>", 0), 0u);

  pc::ContourReport missing;
  EXPECT_THROW((void)pc::report_json(missing), postproc::Error);
}

TEST(ContourReport, LargePathStaysSmall) {
  // 100 000 points on a helix, one error peak: the page stays small, the peak is kept.
  const std::size_t n = 100000;
  pc::Path path;
  path.joints = 2;
  std::vector<double> tip(n), axis(n, 0.0);
  for (std::size_t i = 0; i < n; ++i) {
    pc::PathPoint pt;
    pt.t = 1e-5 * static_cast<double>(i);
    pt.line = i / 4 + 1;
    path.points.push_back(pt);
    tip[i] = 1e-3 * (1 + std::sin(1e-3 * static_cast<double>(i))) + (i == 54321 ? 0.05 : 0.0);
  }
  path.runs.push_back({0, n / 2});
  path.runs.push_back({n / 2, n});
  pc::Prediction pr = prediction(tip, axis);
  for (std::size_t i = 0; i < n; ++i) {
    const double a = 1e-4 * static_cast<double>(i);
    pr.points[i].tip = Eigen::Vector3d(50 * std::cos(a), 50 * std::sin(a), 1e-4 * static_cast<double>(i));
  }
  pc::ContourReport r;
  r.program = "helix.nc";
  r.path = &path;
  r.before = &pr;
  r.after = &pr;
  const std::string h = pc::report_html(r);
  EXPECT_LT(h.size(), 1'500'000u);
  // The 51 µm peak survives the decimation of the time plot: its y axis reaches 60 µm.
  EXPECT_NE(h.find("text-anchor=\"end\">60</text>"), std::string::npos);
  const json j = json::parse(pc::report_json(r));
  EXPECT_EQ(j["worst"][0]["point"], 54321);
  EXPECT_NEAR(j["worst"][0]["tip_um"].get<double>(), 1000 * tip[54321], 1e-6);
  EXPECT_EQ(lines_of(pc::report_csv(r)).size(), n + 1);
}
