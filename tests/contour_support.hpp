#pragma once
// Shared helpers of the contour tests: a 3-axis mill machine file and hand-built paths on it.
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "postproc/contour/path.hpp"
#include "postproc/machine/machine.hpp"

namespace pptest {

/// A 3-axis XYZ mill machine file: tool length 100 mm, G54 at zero, travel ±1000 mm, 4 decimals,
/// Kv 30/s (lag mode) on every axis. `axis_extra` is appended to every [axes.X] table (e.g.
/// limits), `machine_extra` to [machine].
inline std::string mill3_toml(const std::string& axis_extra = "", const std::string& machine_extra = "") {
  std::string s = "[machine]\nname = \"contour test mill\"\ndialect = \"fanuc\"\ninteger_input = \"calculator\"\n"
                  "model = \"serial\"\n" +
                  machine_extra + "\n[tool]\nlength = \"100 mm\"\n\n[work_offsets]\nG54 = { X = 0, Y = 0, Z = 0 }\n\n"
                                  "[serial]\nspindle_point = [0, 0, 0]\n";
  const char* dirs[] = {"[1, 0, 0]", "[0, 1, 0]", "[0, 0, 1]"};
  const char* names[] = {"X", "Y", "Z"};
  for (int a = 0; a < 3; ++a)
    s += fmt::format("\n[[serial.tool_side]]\naxis = \"{}\"\ntype = \"linear\"\ndirection = {}\nmin = -1000\nmax = 1000\n",
                     names[a], dirs[a]);
  for (const char* a : names) s += fmt::format("\n[axes.{}]\ndecimals = 4\nkv = \"30 1/s\"\n{}", a, axis_extra);
  return s;
}

#ifdef POSTPROC_SOURCE_DIR
/// The repository's samples folder (tests built with POSTPROC_SOURCE_DIR).
inline const std::string kSamples = std::string(POSTPROC_SOURCE_DIR) + "/samples/";

/// A machine file of samples/machines, loaded (a failure is a test failure).
inline postproc::machine::Machine sample_machine(const std::string& name) {
  postproc::gcode::DiagnosticSink sink;
  auto m = postproc::machine::load_machine(kSamples + "machines/" + name, sink);
  for (const auto& d : sink.stored())
    if (d.severity == postproc::gcode::Severity::error) ADD_FAILURE() << postproc::gcode::format(d);
  if (!m) throw std::runtime_error("sample machine " + name + " does not load");
  return std::move(*m);
}
#endif

/// The mill above, parsed once.
inline const postproc::machine::Machine& mill() {
  static const postproc::machine::Machine m = [] {
    postproc::gcode::DiagnosticSink sink;
    auto parsed = postproc::machine::parse_machine("mill.toml", mill3_toml(), sink);
    for (const auto& d : sink.stored()) ADD_FAILURE() << postproc::gcode::format(d);
    if (!parsed) throw std::runtime_error("test machine does not parse");
    return std::move(*parsed);
  }();
  return m;
}

/// An empty axis-form path on machine `m` (one controller context, its drives).
inline postproc::contour::Path empty_path(const postproc::machine::Machine& m) {
  postproc::contour::Path p;
  p.joints = m.actual->joint_count();
  p.period = 0.001;
  std::string why;
  auto drives = postproc::contour::joint_drives(m, why);
  EXPECT_TRUE(drives.has_value()) << why;
  if (drives) p.drives = *drives;
  p.maps.emplace_back(m, m.nominal, m.actual, postproc::machine::Form::axes, postproc::gcode::AxisVector::Zero(), false,
                      0.0);
  return p;
}

/// Appends a run through joint positions `qs` at constant speed `v` (mm/s; unlimited
/// acceleration), times continuing from the path's duration; point k gets source line
/// `first_line` + k (0: continue the point numbering).
inline void add_run(postproc::contour::Path& p, const std::vector<postproc::kin::JointVector>& qs, double v,
                    std::uint64_t first_line = 0) {
  const std::size_t begin = p.points.size();
  if (first_line == 0) first_line = p.points.size() + 1;
  double t = p.duration;
  for (std::size_t k = 0; k < qs.size(); ++k) {
    postproc::contour::PathPoint pt;
    pt.q = qs[k];
    pt.line = first_line + k;
    pt.run_start = k == 0;
    postproc::contour::SegmentProfile s;
    if (k > 0) {
      s.length = (qs[k] - qs[k - 1]).norm();
      s.v_cruise = s.v_start = s.v_end = v;
      s.accel = 1e12;
      s.duration = s.length / v;
      t += s.duration;
      pt.speed = k + 1 < qs.size() ? v : 0;
    }
    pt.t = t;
    p.points.push_back(pt);
    p.segments.push_back(s);
  }
  p.runs.push_back(postproc::contour::Run{begin, p.points.size()});
  p.duration = t;
}

inline postproc::kin::JointVector xyz(double x, double y, double z) {
  postproc::kin::JointVector q(3);
  q << x, y, z;
  return q;
}

/// Joint positions of a full circle of radius r (mm) about `centre` in the XY plane, n chords.
inline std::vector<postproc::kin::JointVector> circle(const Eigen::Vector3d& centre, double r, int n) {
  std::vector<postproc::kin::JointVector> qs;
  for (int i = 0; i <= n; ++i) {
    const double a = 2 * postproc::kin::kPi * i / n;
    qs.push_back(xyz(centre.x() + r * std::cos(a), centre.y() + r * std::sin(a), centre.z()));
  }
  return qs;
}

}  // namespace pptest
