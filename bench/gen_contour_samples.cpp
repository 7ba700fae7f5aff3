// postproc_gen_contour_samples: writes the three dense, smooth sample programs of the servo
// contour-error work (issue 6) — deterministic, no randomness.
//
// Regenerate (from the repository root, after building the target):
//
//   nice cmake --build build/release --target postproc_gen_contour_samples -j2
//   build/release/bench/postproc_gen_contour_samples samples/programs [samples/machines]
//
// First argument: output folder; second (optional, default samples/machines): the folder holding
// the machine files. Writes
//   cone_frustum_nas979.nc        trunnion_ac_fanuc.toml   axis positions X Y Z A C, G43 H1, G54
//   freeform_lathe_contour.ngc    lathe_xzbc_doc004.toml   axis positions X Z B C (LinuxCNC, G18)
//   tilted_pocket_3prs_contour.nc hybrid_3prs_doc001.toml  tool tip + virtual A B (Fanuc)
// and prints, per program, the point count, the tool-tip spacing in the workpiece frame (min /
// max over the cutting passes, computed from the ROUNDED values as written, through the nominal
// model) and the axis ranges.
//
// The cutting passes are G1 only, every block carries every axis word of the machine with the
// machine file's output decimals, F2000 on the first feed block of a pass. Machine axis values
// come from the machine's nominal kinematics through the library (machine::ProgramMap, the same
// command ↔ joints map the compensator uses), so they are what the controller would be given.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iostream>
#include <limits>
#include <sstream>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "postproc/machine/program_map.hpp"
#include "postproc/kinematics/model.hpp"
#include "postproc/kinematics/serial.hpp"
#include "postproc/machine/machine.hpp"

namespace {

using postproc::machine::Command;
using postproc::machine::Form;
using postproc::machine::ProgramMap;
using postproc::gcode::AxisVector;
namespace kin = postproc::kin;
namespace machine = postproc::machine;

constexpr double kPi = kin::kPi;
constexpr double kDeg = kin::kDeg;

[[noreturn]] void fail(const std::string& what) {
  std::cerr << "gen_contour_samples: " << what << "\n";
  std::exit(1);
}

machine::Machine load(const std::string& path) {
  postproc::gcode::DiagnosticSink sink;
  auto m = machine::load_machine(path, sink);
  for (const auto& d : sink.stored()) std::cerr << postproc::gcode::format(d) << "\n";
  if (!m) fail("cannot load machine file " + path);
  return std::move(*m);
}

/// The model with parameter "tool.length" set (as compensate_support.cpp ToolLengthModels does).
kin::ModelPtr with_tool_length(const kin::ModelPtr& model, double mm) {
  const int i = model->parameter_index("tool.length");
  if (i < 0) return model;
  std::vector<double> v = model->values();
  v[static_cast<std::size_t>(i)] = mm;
  return model->with_values(std::move(v));
}

AxisVector offset_of(const machine::Machine& m, const std::string& name) {
  const auto it = m.work_offsets.find(name);
  if (it == m.work_offsets.end()) fail("work offset " + name + " missing in " + m.file);
  return it->second;
}

/// Value rounded to the axis's output decimals (no negative zero).
double rounded(const machine::Machine& m, int axis, double v) {
  const double k = std::pow(10.0, m.decimals(axis));
  const double r = std::round(v * k) / k;
  return r == 0.0 ? 0.0 : r;
}

std::string word(const machine::Machine& m, int axis, double v) {
  return fmt::format("{}{:.{}f}", postproc::gcode::kAxisLetters[static_cast<std::size_t>(axis)], rounded(m, axis, v),
                     m.decimals(axis));
}

/// All axis words of `axes` (program axis indices) for command c.
std::string words(const machine::Machine& m, const std::vector<int>& axes, const AxisVector& c) {
  std::string s;
  for (std::size_t i = 0; i < axes.size(); ++i) {
    if (i) s += ' ';
    s += word(m, axes[i], c[axes[i]]);
  }
  return s;
}

AxisVector rounded_all(const machine::Machine& m, const std::vector<int>& axes, const AxisVector& c) {
  AxisVector r = c;
  for (int a : axes) r[a] = rounded(m, a, c[a]);
  return r;
}

struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v) {
    lo = std::min(lo, v);
    hi = std::max(hi, v);
  }
};

/// Statistics of one program's cutting passes, from the values as written.
struct Stats {
  std::size_t points = 0;  ///< cutting-pass blocks (points after the pass start)
  Range spacing;           ///< tool-tip spacing in the workpiece frame, mm
  std::vector<std::pair<int, Range>> axes;
  double max_axis_error_deg = 0;  ///< |tool axis (as written) − intended|
  double max_tip_error_mm = 0;    ///< |tool tip (as written) − intended|
  void print(const std::string& name, const machine::Machine& m) const {
    std::cout << name << ": " << points << " cutting points, tool-tip spacing " << fmt::format("{:.4f}", spacing.lo)
              << " … " << fmt::format("{:.4f}", spacing.hi) << " mm, rounding: tip ≤ "
              << fmt::format("{:.2e}", max_tip_error_mm) << " mm, axis ≤ " << fmt::format("{:.2e}", max_axis_error_deg)
              << "°\n  axes:";
    for (const auto& [a, r] : axes)
      std::cout << " " << postproc::gcode::kAxisLetters[static_cast<std::size_t>(a)] << " ["
                << fmt::format("{:.{}f}", r.lo, m.decimals(a)) << ", " << fmt::format("{:.{}f}", r.hi, m.decimals(a))
                << "]";
    std::cout << "\n";
  }
};

/// Writes numbered Fanuc blocks.
class Blocks {
 public:
  explicit Blocks(bool numbered) : numbered_(numbered) {}
  void add(const std::string& text) {
    if (numbered_) {
      n_ += 10;
      out_ << 'N' << n_ << ' ';
    }
    out_ << text << '\n';
  }
  void raw(const std::string& text) { out_ << text << '\n'; }
  [[nodiscard]] std::string str() const { return out_.str(); }

 private:
  bool numbered_;
  int n_ = 0;
  std::ostringstream out_;
};

void save(const std::string& path, const std::string& text) {
  std::ofstream f(path, std::ios::binary);
  if (!f) fail("cannot write " + path);
  f << text;
  if (!f) fail("write failed: " + path);
}

/// Tool-tip pose of a command through the map (nominal), written-value check helpers.
kin::Pose pose_of(const ProgramMap& map, const Command& c, const kin::JointVector& start, kin::JointVector& q) {
  kin::Pose p;
  if (auto s = map.intended(c, start, p, q); !s.ok()) fail(fmt::format("pose of a written block: {}", kin::to_string(s.status)));
  if (int j = kin::joint_outside_limits(map.nominal(), q); j >= 0)
    fail(fmt::format("joint {} outside its travel ({})", map.nominal().joints()[static_cast<std::size_t>(j)].name, q[j]));
  return p;
}

// ---------------------------------------------------------------------------------------------
// 1. NAS 979 cone frustum on the A/C trunnion (Fanuc, axis positions, G43 H1, G54)

Stats cone(const std::string& machines, const std::string& out) {
  const machine::Machine m = load(machines + "/trunnion_ac_fanuc.toml");
  constexpr int kH = 1;
  const auto hl = m.tool_lengths.find(kH);
  if (hl == m.tool_lengths.end()) fail("H1 missing in trunnion_ac_fanuc.toml");
  const double length = hl->second;  // 85.25 mm
  const kin::ModelPtr nom = with_tool_length(m.nominal, length);
  const AxisVector g54 = offset_of(m, "G54");
  // Axis program, G43 active: joint Z = command Z + offset + tool length (program_map.cpp).
  const ProgramMap map(m, nom, nom, Form::axes, g54, true, length);
  const auto* serial = dynamic_cast<const kin::SerialModel*>(nom.get());
  if (!serial) fail("trunnion model is not serial");
  const std::vector<int> axes = {0, 1, 2, 3, 5};  // X Y Z A C

  // The cone's axis is parallel to C but 40 mm / 25 mm off it (a test piece clamped off-centre,
  // as the cone frustum test of ISO 10791-6 places it), so X, Y, Z and C all move; centred on C
  // the whole pass would be a C rotation alone. A stays at its 15° tilt (the tool axis keeps its
  // inclination from +Z). The pass runs clockwise seen from +Z (climb milling of the outside with
  // M3), starting at the −Y side of the cone.
  constexpr double kXc = 40.0, kYc = 25.0;
  constexpr double kR = 60.0, kZ = -10.0, kTilt = 15.0 * kDeg, kPhi0 = -90.0 * kDeg, kDir = -1.0;
  constexpr int kSegments = 1600;  // 2π·60 / 1600 = 0.2356 mm
  constexpr double kApproach = 25.0;  // mm above the start along the tool axis
  auto tip_pose = [&](double phi, double lift) {
    kin::Pose p;
    const Eigen::Vector3d o(-std::sin(kTilt) * std::cos(phi), -std::sin(kTilt) * std::sin(phi), std::cos(kTilt));
    p.p = Eigen::Vector3d(kXc + kR * std::cos(phi), kYc + kR * std::sin(phi), kZ) + lift * o;
    const Eigen::Vector3d x = o.unitOrthogonal();
    p.r.col(0) = x;
    p.r.col(1) = o.cross(x);
    p.r.col(2) = o;
    return p;
  };
  kin::IkOptions opt;
  opt.match = kin::PoseMatch::point_and_axis;
  auto solve = [&](const kin::Pose& p, const kin::JointVector& start) {
    kin::JointVector q;
    const kin::Solve s = kin::inverse(*nom, p, start, q, opt);
    if (!s.ok()) fail(fmt::format("cone: inverse kinematics {}", kin::to_string(s.status)));
    return q;
  };
  auto command = [&](const kin::JointVector& q) {
    Command c;
    if (!map.command(q, Command{}, c).ok()) fail("cone: command");
    return c.c;
  };

  // First pose: the closed-form orientation branch with C nearest 0, then Newton from it;
  // afterwards each point starts from the previous one (C continuous, no 360° jumps).
  kin::JointVector q0 = kin::JointVector::Zero(nom->joint_count());
  const kin::Pose first = tip_pose(kPhi0, 0);
  const int ja = m.joint_of_axis[3], jc = m.joint_of_axis[5];
  double best = std::numeric_limits<double>::infinity();
  kin::JointVector seed = q0;
  for (const kin::JointVector& c : serial->orientation_candidates(first.axis(), q0)) {
    const double d = std::abs(c[jc]) + 1e-3 * std::abs(c[ja]);
    if (d < best) best = d, seed = c;
  }
  std::vector<kin::JointVector> qs;
  qs.reserve(kSegments + 1);
  kin::JointVector q = solve(first, seed);
  for (int k = 0; k <= kSegments; ++k) {
    const double phi = kPhi0 + kDir * 2 * kPi * k / kSegments;
    q = solve(tip_pose(phi, 0), q);
    if (!qs.empty() && std::abs(q[jc] - qs.back()[jc]) > 5.0) fail("cone: C jumped");
    qs.push_back(q);
  }
  const AxisVector start_c = command(qs.front());
  const AxisVector above_start = command(solve(tip_pose(kPhi0, kApproach), qs.front()));
  const AxisVector above_end = command(solve(tip_pose(kPhi0 + kDir * 2 * kPi, kApproach), qs.back()));
  // No straight lead-in / lead-out: a tangent line held at constant C meets the pass with a
  // corner in joint space (C starts turning at once), whose servo transient would dominate the
  // figures. The pass starts at rest after an exact stop and ends at rest where it began, after
  // an exit feed ramp.

  Blocks b(true);
  b.raw("%");
  b.raw("O6001 (NAS 979 CONE FRUSTUM - FLANK PASS, AXIS POSITIONS, NO TCP)");
  b.raw("(MACHINE: TRUNNION A/C, FANUC - SAMPLES/MACHINES/TRUNNION_AC_FANUC.TOML)");
  b.raw("(TOOL TIP ON A CIRCLE R60 AT Z-10 ABOUT X40 Y25 IN THE WORKPIECE FRAME - CONE OFF THE C AXIS -)");
  b.raw("(TOOL AXIS 15 DEG FROM +Z LEANING INWARD ALONG THE GENERATOR OF A 15 DEG HALF-ANGLE CONE,)");
  b.raw("(AZIMUTH = TIP ANGLE, CLOCKWISE SEEN FROM +Z - CLIMB MILLING WITH M3,)");
  b.raw(fmt::format("(FULL 360 DEG, {} POINTS, TIP SPACING {:.4f} MM, F2000, EXIT RAMP TO F200 OVER THE LAST 40 BLOCKS.)", kSegments + 1,
                    2 * kPi * kR / kSegments));
  b.raw("(AXIS VALUES FROM THE NOMINAL INVERSE KINEMATICS WITH H1 = 85.25 MM, G54 = 0. GENERATED BY BENCH/GEN_CONTOUR_SAMPLES.CPP)");
  b.add("G21 G90 G94 G17 G40 G49 G80");
  b.add("G54");
  b.add("T1 M6");
  b.add("S12000 M3");
  b.add("G0 X0. Y0. Z150. A0. C0.");
  b.add(fmt::format("G43 H{} Z150.", kH));
  b.add(fmt::format("G0 {} {}", word(m, 3, above_start[3]), word(m, 5, above_start[5])));
  b.add(fmt::format("G0 {} {}", word(m, 0, above_start[0]), word(m, 1, above_start[1])));
  b.add(fmt::format("G0 {}", word(m, 2, above_start[2])));
  b.add(fmt::format("G9 G1 {} F500.", words(m, axes, start_c)));  // exact stop before the pass
  // Exit feed ramp: the last kRamp blocks slow from F2000 to F200, so that the machine stops with
  // little lag left (a stop at full speed settles along the chord of the last millimetre).
  constexpr std::size_t kRamp = 40;
  for (std::size_t k = 1; k < qs.size(); ++k) {
    std::string f = k == 1 ? " F2000." : "";
    if (k + kRamp >= qs.size()) {
      const double frac = static_cast<double>(k + kRamp + 1 - qs.size()) / kRamp;
      f = fmt::format(" F{:.0f}.", 2000.0 - 1800.0 * frac);
    }
    b.add(words(m, axes, command(qs[k])) + f);
  }
  b.add(fmt::format("G0 {}", words(m, axes, above_end)));
  b.add("G0 Z150.");
  b.add("G49 G0 A0.");
  b.add("M5");
  b.add("M30");
  b.raw("%");
  save(out + "/cone_frustum_nas979.nc", b.str());

  // Statistics from the rounded values.
  Stats st;
  st.points = qs.size() - 1;
  for (int a : axes) st.axes.emplace_back(a, Range{});
  Eigen::Vector3d prev = Eigen::Vector3d::Zero();
  kin::JointVector qq = qs.front();
  for (std::size_t k = 0; k < qs.size(); ++k) {
    Command c;
    c.c = rounded_all(m, axes, command(qs[k]));
    const kin::Pose p = pose_of(map, c, qq, qq);
    const kin::Pose want = tip_pose(kPhi0 + kDir * 2 * kPi * static_cast<double>(k) / kSegments, 0);
    st.max_tip_error_mm = std::max(st.max_tip_error_mm, (p.p - want.p).norm());
    st.max_axis_error_deg =
        std::max(st.max_axis_error_deg, std::acos(std::clamp(p.axis().dot(want.axis()), -1.0, 1.0)) / kDeg);
    if (k) st.spacing.add((p.p - prev).norm());
    prev = p.p;
    for (auto& [a, r] : st.axes) r.add(c.c[a]);
  }
  return st;
}

// ---------------------------------------------------------------------------------------------
// 2. Freeform X Z B C pass on the lathe of document 004 (LinuxCNC, axis positions, G54)

Stats lathe(const std::string& machines, const std::string& out) {
  const machine::Machine m = load(machines + "/lathe_xzbc_doc004.toml");
  const kin::ModelPtr nom = m.nominal;  // tool length: [tool] length (no G43 in the program)
  const AxisVector g54 = offset_of(m, "G54");
  const ProgramMap map(m, nom, nom, Form::axes, g54, false, m.tool_length);
  const std::vector<int> axes = {0, 2, 4, 5};  // X Z B C

  // The pass as a function of s ∈ [0, 1]: C two turns, Z advancing 40 mm toward the chuck,
  // X (radius word) 40 + 3·sin(3·C) (three lobes per turn), B = −20°·sin(π·s).
  auto axes_at = [](double s) {
    AxisVector c = AxisVector::Zero();
    const double cdeg = -360.0 + 720.0 * s;
    c[5] = cdeg;
    c[2] = -40.0 * s;
    c[0] = 40.0 + 3.0 * std::sin(3.0 * cdeg * kDeg);
    c[4] = -20.0 * std::sin(kPi * s);
    return c;
  };
  kin::JointVector qs = kin::JointVector::Zero(nom->joint_count());
  auto tip = [&](const AxisVector& c) {
    Command cmd;
    cmd.c = c;
    return pose_of(map, cmd, qs, qs).p;
  };
  // Arc-length parametrisation of the tool tip in the workpiece frame: a fine table s → length,
  // then points at equal length steps (target 0.35 mm).
  constexpr int kFine = 200000;
  constexpr double kTarget = 0.35;
  std::vector<double> len(kFine + 1, 0.0);
  Eigen::Vector3d prev = tip(axes_at(0));
  for (int i = 1; i <= kFine; ++i) {
    const Eigen::Vector3d p = tip(axes_at(static_cast<double>(i) / kFine));
    len[static_cast<std::size_t>(i)] = len[static_cast<std::size_t>(i) - 1] + (p - prev).norm();
    prev = p;
  }
  const double total = len.back();
  const int n = static_cast<int>(std::ceil(total / kTarget));
  std::vector<AxisVector> pts;
  std::size_t i = 0;
  for (int k = 0; k <= n; ++k) {
    const double l = total * k / n;
    while (i + 1 < len.size() && len[i + 1] < l) ++i;
    const double t = i + 1 < len.size() ? (l - len[i]) / std::max(len[i + 1] - len[i], 1e-300) : 0.0;
    pts.push_back(axes_at((static_cast<double>(i) + std::clamp(t, 0.0, 1.0)) / kFine));
  }

  const AxisVector& s0 = pts.front();
  const AxisVector& s1 = pts.back();
  Blocks b(false);
  b.raw("%");
  b.raw("(FREEFORM X Z B C CONTOUR - 4-AXIS LATHE OF DOCUMENT 004, DENSE SMOOTH PASS)");
  b.raw("(MACHINE: SAMPLES/MACHINES/LATHE_XZBC_DOC004.TOML, LINUXCNC, RADIUS MODE, AXIS POSITIONS)");
  b.raw("(C TURNS TWO FULL TURNS -360 -> 360 WHILE Z ADVANCES 40 MM TOWARD THE CHUCK,)");
  b.raw("(X = 40 + 3 SIN[3 C] - THREE LOBES PER TURN, B = -20 SIN[180 S] TILTS THE TOOL AND BACK)");
  b.raw(fmt::format("({} POINTS AT EQUAL TOOL-TIP STEPS OF {:.4f} MM ON THE PART - WORKPIECE FRAME)", n + 1, total / n));
  b.raw("(GENERATED BY BENCH/GEN_CONTOUR_SAMPLES.CPP)");
  b.add("G21 G90 G94 G18 G8");
  b.add("G54");
  b.add("T1 M6");
  b.add(fmt::format("G0 X60. Z10. B0. {}", word(m, 5, s0[5])));
  b.add(fmt::format("G0 {} {}", word(m, 0, s0[0] + 10.0), word(m, 2, s0[2] + 5.0)));
  b.add(fmt::format("G61.1 G1 {} F500.", words(m, axes, s0)));  // exact stop at the end of the approach
  for (std::size_t k = 1; k < pts.size(); ++k)
    b.add((k == 1 ? "G64 " : "") + words(m, axes, pts[k]) + (k == 1 ? " F2000." : ""));
  b.add(fmt::format("G0 {}", word(m, 0, s1[0] + 10.0)));
  b.add("G0 X60.");
  b.add("Z10. B0.");
  b.add("M30");
  b.raw("%");
  save(out + "/freeform_lathe_contour.ngc", b.str());

  Stats st;
  st.points = pts.size() - 1;
  for (int a : axes) st.axes.emplace_back(a, Range{});
  for (std::size_t k = 0; k < pts.size(); ++k) {
    Command c;
    c.c = rounded_all(m, axes, pts[k]);
    Command exact;
    exact.c = pts[k];
    const kin::Pose p = pose_of(map, c, qs, qs);
    kin::JointVector qe = qs;
    const kin::Pose pe = pose_of(map, exact, qe, qe);
    st.max_tip_error_mm = std::max(st.max_tip_error_mm, (p.p - pe.p).norm());
    st.max_axis_error_deg =
        std::max(st.max_axis_error_deg, std::acos(std::clamp(p.axis().dot(pe.axis()), -1.0, 1.0)) / kDeg);
    if (k) st.spacing.add((p.p - prev).norm());
    prev = p.p;
    for (auto& [a, r] : st.axes) r.add(c.c[a]);
  }
  return st;
}

// ---------------------------------------------------------------------------------------------
// 3. Tilted pocket on the 3-PRS hybrid (Fanuc, tool tip + virtual A B, G54)

Stats pocket(const std::string& machines, const std::string& out) {
  const machine::Machine m = load(machines + "/hybrid_3prs_doc001.toml");
  const AxisVector g54 = offset_of(m, "G54");
  const ProgramMap map(m, m.nominal, m.nominal, Form::tcp_virtual, g54, false, m.tool_length);
  const std::vector<int> axes = {0, 1, 2, 3, 4};  // X Y Z A B

  constexpr double kA = 12.0, kB = -15.0;
  // The plane's frame: R = Rx(A)·Ry(B); u = R·x̂, v = R·ŷ lie in the plane, n = R·ẑ is its normal
  // (= the tool axis O of the virtual angles). The pocket floor passes through (0, 0, −2).
  const Eigen::Matrix3d r =
      (Eigen::AngleAxisd(kA * kDeg, Eigen::Vector3d::UnitX()) * Eigen::AngleAxisd(kB * kDeg, Eigen::Vector3d::UnitY()))
          .toRotationMatrix();
  const Eigen::Vector3d u = r.col(0), v = r.col(1), nrm = r.col(2);
  if ((nrm - postproc::machine::virtual_ab_axis(kA, kB)).norm() > 1e-12) fail("pocket: plane normal ≠ virtual A B axis");
  const Eigen::Vector3d centre(0, 0, -2);
  constexpr double kRadius = 8.0, kTarget = 0.3, kApproach = 20.0;
  struct Loop {
    double w, h;
  };
  const std::vector<Loop> loops = {{60, 30}, {70, 40}, {80, 50}};  // inside out

  // A point of a rounded rectangle (w × h, corner radius kRadius) at arc length l from the middle
  // of its −v side, counter-clockwise (seen from +n), in plane coordinates (a, b).
  auto rounded_rect = [&](const Loop& lp, double l) {
    const double hx = lp.w / 2 - kRadius, hy = lp.h / 2 - kRadius;  // straight half-lengths
    const double arc = kRadius * kPi / 2;
    const double seg[8] = {hx, arc, 2 * hy, arc, 2 * hx, arc, 2 * hy, arc};
    const double total = 4 * hx + 4 * hy + 4 * arc;
    l = std::fmod(l, total);
    // Sides and corners in order, the first side from (0, −h/2) to (hx, −h/2).
    for (int s = 0; s < 9; ++s) {
      const int k = s % 8;
      const double len = s == 8 ? hx : seg[k];
      if (l > len && s < 8) {
        l -= len;
        continue;
      }
      switch (k) {
        case 0: return Eigen::Vector2d(s == 8 ? -hx + l : l, -lp.h / 2);
        case 1: { const double t = -kPi / 2 + l / kRadius; return Eigen::Vector2d(hx + kRadius * std::cos(t), -hy + kRadius * std::sin(t)); }
        case 2: return Eigen::Vector2d(lp.w / 2, -hy + l);
        case 3: { const double t = l / kRadius; return Eigen::Vector2d(hx + kRadius * std::cos(t), hy + kRadius * std::sin(t)); }
        case 4: return Eigen::Vector2d(hx - l, lp.h / 2);
        case 5: { const double t = kPi / 2 + l / kRadius; return Eigen::Vector2d(-hx + kRadius * std::cos(t), hy + kRadius * std::sin(t)); }
        case 6: return Eigen::Vector2d(-lp.w / 2, hy - l);
        default: { const double t = kPi + l / kRadius; return Eigen::Vector2d(-hx + kRadius * std::cos(t), -hy + kRadius * std::sin(t)); }
      }
    }
    return Eigen::Vector2d(0, -lp.h / 2);
  };
  auto command_at = [&](const Eigen::Vector3d& p) {
    AxisVector c = AxisVector::Zero();
    c.head<3>() = p - g54.head<3>();
    c[3] = kA - g54[3];
    c[4] = kB - g54[4];
    return c;
  };

  std::vector<std::vector<AxisVector>> passes;
  for (const Loop& lp : loops) {
    const double hx = lp.w / 2 - kRadius, hy = lp.h / 2 - kRadius;
    const double total = 4 * hx + 4 * hy + 2 * kPi * kRadius;
    const int n = static_cast<int>(std::lround(total / kTarget));
    std::vector<AxisVector> pts;
    for (int k = 0; k <= n; ++k) {
      const Eigen::Vector2d ab = k == n ? Eigen::Vector2d(0, -lp.h / 2) : rounded_rect(lp, total * k / n);
      pts.push_back(command_at(centre + ab.x() * u + ab.y() * v));
    }
    passes.push_back(std::move(pts));
  }
  const AxisVector above_start = command_at(passes.front().front().head<3>() + g54.head<3>() + kApproach * nrm);
  const AxisVector above_end = command_at(passes.back().back().head<3>() + g54.head<3>() + kApproach * nrm);

  Blocks b(true);
  b.raw("%");
  b.raw("O6003 (TILTED POCKET CONTOUR - 3-PRS HYBRID, TOOL TIP + VIRTUAL A B, DENSE LOOPS)");
  b.raw("(MACHINE: SAMPLES/MACHINES/HYBRID_3PRS_DOC001.TOML, FANUC, O = RX[A] RY[B] Z)");
  b.raw("(POCKET FLOOR: THE PLANE THROUGH X0 Y0 Z-2 TILTED A12 B-15, TOOL AXIS NORMAL TO IT)");
  b.raw("(3 ROUNDED-RECTANGLE LOOPS IN THE PLANE, INSIDE OUT: 60X30, 70X40, 80X50 MM, CORNER R8,)");
  b.raw(fmt::format("(TIP STEP {:.1f} MM, EACH LOOP STARTS/ENDS MID -V SIDE, 5 MM G1 STEP-OVER BETWEEN LOOPS, G9 EXACT STOPS)", kTarget));
  b.raw("(GENERATED BY BENCH/GEN_CONTOUR_SAMPLES.CPP)");
  b.add("G21 G90 G94 G17 G54");
  b.add("T3 M6");
  b.add("S18000 M3");
  b.add("G0 X0. Y0. Z50. A0. B0.");
  b.add(fmt::format("G0 {}", words(m, axes, above_start)));
  b.add(fmt::format("G9 G1 {} F500.", words(m, axes, passes.front().front())));
  // Exact stops (G9) at the end of every loop and of every step-over: the corners are cut at rest.
  for (std::size_t p = 0; p < passes.size(); ++p) {
    if (p) b.add("G9 " + words(m, axes, passes[p].front()));  // step-over (F modal)
    for (std::size_t k = 1; k < passes[p].size(); ++k)
      b.add((k + 1 == passes[p].size() ? "G9 " : "") + words(m, axes, passes[p][k]) + (k == 1 ? " F2000." : ""));
  }
  b.add(fmt::format("G0 {}", words(m, axes, above_end)));
  b.add("G0 Z50.");
  b.add("X0. Y0. A0. B0.");
  b.add("M30");
  b.raw("%");
  save(out + "/tilted_pocket_3prs_contour.nc", b.str());

  Stats st;
  for (int a : axes) st.axes.emplace_back(a, Range{});
  kin::JointVector q = kin::JointVector::Zero(m.nominal->joint_count());
  {  // a start near the pocket for the first solve
    Command c;
    c.c = passes.front().front();
    kin::Pose p;
    if (!map.intended(c, q, p, q).ok()) fail("pocket: first pose");
  }
  for (const auto& pass : passes) {
    st.points += pass.size() - 1;
    Eigen::Vector3d prev = Eigen::Vector3d::Zero();
    for (std::size_t k = 0; k < pass.size(); ++k) {
      Command c;
      c.c = rounded_all(m, axes, pass[k]);
      const kin::Pose p = pose_of(map, c, q, q);
      const Eigen::Vector3d want = pass[k].head<3>() + g54.head<3>();
      st.max_tip_error_mm = std::max(st.max_tip_error_mm, (p.p - want).norm());
      st.max_axis_error_deg =
          std::max(st.max_axis_error_deg, std::acos(std::clamp(p.axis().dot(nrm), -1.0, 1.0)) / kDeg);
      // off-plane distance of the written tip (rounding only)
      st.max_tip_error_mm = std::max(st.max_tip_error_mm, std::abs((p.p - centre).dot(nrm)));
      if (k) st.spacing.add((p.p - prev).norm());
      prev = p.p;
      for (auto& [a, rg] : st.axes) rg.add(c.c[a]);
    }
  }
  return st;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || argc > 3) {
    std::cerr << "usage: postproc_gen_contour_samples OUT_DIR [MACHINE_DIR=samples/machines]\n";
    return 2;
  }
  const std::string out = argv[1];
  const std::string machines = argc > 2 ? argv[2] : "samples/machines";
  try {
    cone(machines, out).print("cone_frustum_nas979.nc", load(machines + "/trunnion_ac_fanuc.toml"));
    lathe(machines, out).print("freeform_lathe_contour.ngc", load(machines + "/lathe_xzbc_doc004.toml"));
    pocket(machines, out).print("tilted_pocket_3prs_contour.nc", load(machines + "/hybrid_3prs_doc001.toml"));
  } catch (const std::exception& e) {
    fail(e.what());
  }
  return 0;
}
