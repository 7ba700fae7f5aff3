// The HTML report of postproc diff (issue 7): sections, figures, escaping, no network resources,
// decimation of the 3-D view, and the degenerate cases.
#include "postproc/compensation/diff_report.hpp"

#include <cmath>
#include <string>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "contour_support.hpp"
#include "postproc/contour/reference.hpp"
#include "postproc/error.hpp"
#include "postproc/gcode/line_reader.hpp"

namespace {

namespace comp = postproc::comp;
namespace gc = postproc::gcode;
namespace pc = postproc::contour;

const gc::Dialect& fanuc() {
  static const gc::Dialect d = *gc::make_dialect(pptest::mill().dialect_name, pptest::mill().dialect_options);
  return d;
}

std::size_t count(const std::string& h, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = h.find(what); at != std::string::npos; at = h.find(what, at + what.size())) ++n;
  return n;
}

/// The text of the element with id `id` (up to the next '<').
std::string text_of(const std::string& h, const std::string& id) {
  const std::size_t at = h.find(fmt::format("id=\"{}\">", id));
  if (at == std::string::npos) return "(missing)";
  const std::size_t begin = h.find('>', at) + 1;
  return h.substr(begin, h.find('<', begin) - begin);
}

/// The JSON embedded for the 3-D view.
nlohmann::json view_data(const std::string& h) {
  const std::string open = "<script type=\"application/json\" id=\"view3d-data\">";
  const std::size_t begin = h.find(open);
  if (begin == std::string::npos) return nullptr;
  const std::size_t from = begin + open.size();
  return nlohmann::json::parse(h.substr(from, h.find("</script>", from) - from));
}

void expect_self_contained(const std::string& h) {
  EXPECT_EQ(h.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_EQ(count(h, "<svg"), count(h, "</svg>"));
  EXPECT_EQ(count(h, "http://"), count(h, "http://www.w3.org/2000/svg"));
  EXPECT_EQ(count(h, "https://"), 0u);
  EXPECT_EQ(count(h, "src="), 0u);
  EXPECT_EQ(count(h, "@import"), 0u);
  EXPECT_EQ(count(h, "url("), 0u);
}

const std::string kOriginal = "(cut a<b & c)\nG90 G54\nG0 X0 Y0 Z10.\nG1 Z0 F500\nX10. Y5.\nX20.\nY10.\n";
const std::string kCorrected = "(cut a<b & c)\nG90 G54\nG0 X0 Y0 Z10.\nG1 Z0 F500\nX10.003 Y4.996 (moved <here>)\nX20.\nY10.\n";

TEST(DiffReport, SectionsFiguresAndEscaping) {
  gc::DiagnosticSink sink;
  const comp::DiffResult d = comp::diff(kOriginal, kCorrected, "a<b.nc", "b.nc", fanuc(), &pptest::mill(), sink);
  ASSERT_FALSE(sink.has_errors());
  comp::DiffReport r;
  r.result = &d;
  r.original_file = "a<b.nc";
  r.corrected_file = "b.nc";
  r.machine_file = "mill.toml";
  r.machine_sha256 = "abc";
  r.tool_version = "1.2.3";
  r.original_text = kOriginal;
  r.corrected_text = kCorrected;
  const std::string h = comp::diff_report_html(r);
  expect_self_contained(h);
  for (const char* id : {"summary", "projection-xy", "projection-xz", "projection-yz", "view3d", "view3d-data",
                         "along-path", "along-path-angle", "histogram", "worst"})
    EXPECT_NE(h.find(fmt::format("id=\"{}\"", id)), std::string::npos) << id;
  EXPECT_EQ(h.find("id=\"contour\""), std::string::npos);  // no predictions given
  // The summary's figures are the result's, rounded as the CLI prints them.
  EXPECT_EQ(text_of(h, "max-um"), fmt::format("{:.3f}", d.deviation.max * 1000));
  EXPECT_EQ(text_of(h, "max-um"), "5.000");
  EXPECT_EQ(text_of(h, "rms-um"), fmt::format("{:.3f}", d.deviation.rms * 1000));
  EXPECT_EQ(text_of(h, "p95-um"), fmt::format("{:.3f}", d.deviation.p95 * 1000));
  EXPECT_EQ(text_of(h, "angle-max-arcsec"), "0.00");
  EXPECT_EQ(text_of(h, "pairs"), std::to_string(d.blocks.size()));
  EXPECT_EQ(text_of(h, "changed"), std::to_string(d.changed));
  EXPECT_EQ(text_of(h, "unmatched"), "0");
  EXPECT_EQ(text_of(h, "aligned"), "by block");
  EXPECT_EQ(text_of(h, "motions-original"), "5");
  EXPECT_EQ(text_of(h, "measure"), "tool-tip distance");
  // The worst block's source lines, escaped.
  EXPECT_NE(h.find("<code>X10.003 Y4.996 (moved &lt;here&gt;)</code>"), std::string::npos);
  EXPECT_NE(h.find("<code>X10. Y5.</code>"), std::string::npos);
  EXPECT_EQ(h.find("<here>"), std::string::npos);
  EXPECT_NE(h.find("a&lt;b.nc"), std::string::npos);
  EXPECT_EQ(h.find("a<b"), std::string::npos);
  // The points are the intended tool tips: the mill's axis values less its 100 mm tool.
  ASSERT_TRUE(d.blocks[2].point_known);
  EXPECT_NEAR((d.blocks[2].point_mm - Eigen::Vector3d(10, 5, -100)).norm(), 0, 1e-9);
  const nlohmann::json v = view_data(h);
  ASSERT_TRUE(v.is_object());
  EXPECT_EQ(v["p"].size(), 3 * d.blocks.size());
  EXPECT_NEAR(v["max"].get<double>(), 5.0, 1e-6);
  // Headings carry units.
  EXPECT_NE(h.find("deviation (µm)"), std::string::npos);
  EXPECT_NE(h.find("(arcsec)"), std::string::npos);
  EXPECT_NE(h.find("rotary change (deg)"), std::string::npos);
  EXPECT_EQ(h, comp::diff_report_html(r));  // deterministic
}

TEST(DiffReport, WithoutMachineUsesAxisValues) {
  gc::DiagnosticSink sink;
  const comp::DiffResult d = comp::diff(kOriginal, kCorrected, "a.nc", "b.nc", fanuc(), nullptr, sink);
  ASSERT_FALSE(sink.has_errors());
  EXPECT_FALSE(d.with_machine);
  comp::DiffReport r;
  r.result = &d;
  r.original_text = kOriginal;
  r.corrected_text = kCorrected;
  const std::string h = comp::diff_report_html(r);
  expect_self_contained(h);
  EXPECT_EQ(text_of(h, "measure"), "linear-axis change");
  EXPECT_EQ(h.find("id=\"angle-max-arcsec\""), std::string::npos);
  EXPECT_EQ(h.find("id=\"along-path-angle\""), std::string::npos);
  EXPECT_NE(h.find("id=\"projection-xz\""), std::string::npos);
  ASSERT_TRUE(d.blocks[2].point_known);
  EXPECT_EQ(d.blocks[2].point_mm, Eigen::Vector3d(10, 5, 0));
}

TEST(DiffReport, EmptyAndSinglePair) {
  for (const std::string& prog : {std::string("G90 G54\n"), std::string("G90 G54\nG0 X1. Y2. Z3.\n")}) {
    gc::DiagnosticSink sink;
    const comp::DiffResult d = comp::diff(prog, prog, "a.nc", "a.nc", fanuc(), &pptest::mill(), sink);
    comp::DiffReport r;
    r.result = &d;
    r.original_text = prog;
    r.corrected_text = prog;
    const std::string h = comp::diff_report_html(r);
    expect_self_contained(h);
    EXPECT_NE(h.find("id=\"view3d\""), std::string::npos);
    EXPECT_EQ(text_of(h, "pairs"), std::to_string(d.blocks.size()));
    EXPECT_EQ(text_of(h, "max-um"), "0.000");
  }
  // Without the programs' texts the source cells stay empty; without a result it throws.
  comp::DiffResult one;
  one.blocks.push_back(comp::BlockDiff{});
  one.blocks.back().line_original = 7;
  comp::DiffReport r;
  r.result = &one;
  EXPECT_NO_THROW((void)comp::diff_report_html(r));
  comp::DiffReport missing;
  EXPECT_THROW((void)comp::diff_report_html(missing), postproc::Error);
}

TEST(DiffReport, LargeResultIsDecimatedAndKeepsThePeak) {
  const std::size_t n = 100000;
  comp::DiffResult d;
  d.with_machine = true;
  for (std::size_t i = 0; i < n; ++i) {
    comp::BlockDiff b;
    const double a = 1e-3 * static_cast<double>(i);
    b.point_mm = Eigen::Vector3d(50 * std::cos(a), 50 * std::sin(a), 1e-3 * static_cast<double>(i));
    b.point_known = i != 500;  // one gap: two stretches
    b.deviation_mm = i == 54321 ? 0.05 : 1e-3 * (1 + std::sin(a));
    b.tip_mm = b.deviation_mm;
    b.axis_rad = 0;
    b.line_original = b.line_corrected = i + 1;
    d.blocks.push_back(b);
  }
  comp::DiffReport r;
  r.result = &d;
  const std::string h = comp::diff_report_html(r);
  EXPECT_LT(h.size(), 2'000'000u);
  const nlohmann::json v = view_data(h);
  ASSERT_TRUE(v.is_object());
  ASSERT_LE(v["v"].size(), comp::kDiffView3dMaxPoints);
  EXPECT_GT(v["v"].size(), comp::kDiffView3dMaxPoints / 2);
  EXPECT_EQ(v["p"].size(), 3 * v["v"].size());
  EXPECT_EQ(v["s"].size(), v["v"].size());
  double peak = 0;
  std::size_t starts = 0;
  for (const auto& x : v["v"]) peak = std::max(peak, x.get<double>());
  for (const auto& x : v["s"]) starts += x.get<int>();
  EXPECT_NEAR(peak, 50.0, 1e-6);  // the 50 µm peak survives
  EXPECT_EQ(starts, 2u);          // the gap splits the path
  EXPECT_NE(h.find(fmt::format("{} of {} points drawn", v["v"].size(), n - 1)), std::string::npos);
}

TEST(DiffReport, PredictedContourSection) {
  // A circle on the mill at 6000 mm/min: the lag takes the tip inside it.
  const std::string prog = "G90 G54\nG0 X10. Y0 Z0\nG1 X10. Y0 F6000\nG3 X10. Y0 I-10. J0\n";
  gc::DiagnosticSink sink;
  const postproc::machine::Machine& m = pptest::mill();
  const comp::DiffResult d = comp::diff(prog, prog, "a.nc", "a.nc", fanuc(), &m, sink);
  gc::LineReader in{std::string_view(prog)};
  const pc::Path path = pc::build_path(in, "a.nc", fanuc(), m, pc::PathOptions{}, sink);
  ASSERT_FALSE(sink.has_errors());
  const pc::Reference ref(path, *m.actual);
  const pc::Prediction before = pc::predict(path, *m.actual, ref);
  comp::DiffReport r;
  r.result = &d;
  r.path = &path;
  r.predicted_before = &before;
  r.predicted_after = &before;
  const std::string h = comp::diff_report_html(r);
  expect_self_contained(h);
  for (const char* id : {"contour", "contour-summary", "contour-tip", "contour-axis"})
    EXPECT_NE(h.find(fmt::format("id=\"{}\"", id)), std::string::npos) << id;
  ASSERT_GT(before.tip.max, 1e-6);
  EXPECT_EQ(text_of(h, "contour-original-tip-max-um"), fmt::format("{:.3f}", before.tip.max * 1000));
  EXPECT_EQ(text_of(h, "contour-corrected-tip-max-um"), fmt::format("{:.3f}", before.tip.max * 1000));
}

}  // namespace
