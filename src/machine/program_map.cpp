// The controller's command → joints map per program form, and the geometric remap through it.
#include "postproc/machine/program_map.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include <fmt/format.h>

#include <Eigen/QR>

#include "postproc/kinematics/bounded_inverse.hpp"
#include "postproc/kinematics/hexapod.hpp"
#include "postproc/kinematics/serial.hpp"

namespace postproc::machine {

std::string_view to_string(Form f) {
  switch (f) {
    case Form::axes: return "axis positions";
    case Form::tcp_rotary: return "tool tip + rotary axes";
    case Form::tcp_vector: return "tool tip + tool vector";
    case Form::tcp_virtual: return "tool tip + virtual A B";
    case Form::turning: return "axis positions, turning (spindle running)";
  }
  return "?";
}

Form form_of(const machine::Machine& m, const gcode::Motion& mo) {
  if (m.coordinates == machine::ProgramCoordinates::tool_tip)
    return m.orientation == machine::Orientation::virtual_ab ? Form::tcp_virtual : Form::tcp_vector;
  if (m.turning_spindle_axis >= 0 && mo.spindle_turning && mo.tcp == gcode::TcpMode::off) return Form::turning;
  if (mo.frame == gcode::Frame::machine) return Form::axes;
  switch (mo.tcp) {
    case gcode::TcpMode::off: return Form::axes;
    case gcode::TcpMode::fanuc_g43_5: return Form::tcp_vector;
    case gcode::TcpMode::siemens_traori: return mo.tool_vector_known ? Form::tcp_vector : Form::tcp_rotary;
    default: return Form::tcp_rotary;
  }
}

std::optional<gcode::AxisVector> program_offset(const machine::Machine& m, const gcode::Motion& mo) {
  if (mo.frame != gcode::Frame::work) return gcode::AxisVector::Zero();
  if (mo.position_offset_unknown != 0) return std::nullopt;  // the G92 shift is not known
  if (mo.work_offset_rewritten) return std::nullopt;          // the program wrote the offset (G10)
  const auto it = m.work_offsets.find(machine::work_offset_name(mo.work_offset));
  if (it == m.work_offsets.end()) return std::nullopt;
  gcode::AxisVector origin = it->second;
  // The axes the program wrote (G10 L2 with plain numbers) lie where it put them.
  for (int a = 0; a < gcode::kAxisCount; ++a)
    if (mo.work_offset_written & (1u << a)) origin[a] = mo.work_offset_value[a];
  return gcode::AxisVector(origin + mo.local_offset + mo.position_offset);
}

std::string program_offset_refusal(const machine::Machine& m, const gcode::Motion& mo) {
  if (mo.frame == gcode::Frame::work && mo.position_offset_unknown != 0) {
    std::string axes;
    for (int a = 0; a < gcode::kAxisCount; ++a)
      if (mo.position_offset_unknown & (1u << a)) axes += gcode::kAxisLetters[static_cast<std::size_t>(a)];
    return fmt::format("the G92 shift of {} is not known: G92 was given where the position of {} was unknown (after "
                       "G28/G30, probing or an unknown work offset), so the program's coordinates cannot be placed on "
                       "the machine; move the axes to a known point before G92, or use a work offset (G54…) that the "
                       "machine file gives",
                       axes, axes);
  }
  const std::string name = machine::work_offset_name(mo.work_offset);
  if (mo.frame == gcode::Frame::work && mo.work_offset_rewritten && mo.work_offset.code10 == 2470)
    return "a CYCL DEF 247 (datum setting) before this move activates a preset whose row the program does not give as "
           "a number (Q339): where the coordinates lie on the machine is not known; give Q339 as a number";
  if (mo.frame == gcode::Frame::work && mo.work_offset_rewritten)
    return fmt::format("the program wrote work offset {} (G10 L2/L20) before this move: the machine file's {} is not "
                       "where the controller puts it now (and a G10 offset written from the current position, or with a "
                       "rotation, is not known here); give the offset in the machine file's [work_offsets] and take "
                       "the G10 out of the program",
                       name, name);
  return fmt::format("work offset {} is not in machine file {}; add [work_offsets] {} = {{ X = …, Y = …, Z = … }} with "
                     "the controller's values",
                     name, m.file, name);
}

Eigen::Vector3d virtual_ab_axis(double a_deg, double b_deg) {
  const double a = a_deg * kin::kDeg;
  const double b = b_deg * kin::kDeg;
  return {std::sin(b), -std::sin(a) * std::cos(b), std::cos(a) * std::cos(b)};
}

Eigen::Vector2d virtual_ab_angles(const Eigen::Vector3d& o) {
  const Eigen::Vector3d u = o.normalized();
  const double b = std::asin(std::clamp(u.x(), -1.0, 1.0));
  const double a = std::atan2(-u.y(), u.z());
  return {a / kin::kDeg, b / kin::kDeg};
}

namespace {

/// Of the two closed-form orientation solutions of a serial machine, the one whose tilting axis
/// (the rotary joint that flips sign between them; the other turns by half a turn) has the sign
/// asked for; nullopt when there are not two, or the tilt is 0 (both solutions meet there: the
/// nearest rule decides).
std::optional<std::size_t> branch_by_tilt_sign(const kin::Model& model, const std::vector<kin::JointVector>& c,
                                               bool positive) {
  if (c.size() != 2) return std::nullopt;
  const auto wrap = [](double deg) { return std::remainder(deg, 360.0); };  // (−180, 180]
  for (int j = 0; j < model.joint_count(); ++j) {
    if (model.joints()[static_cast<std::size_t>(j)].type != kin::JointType::rotary) continue;
    const double a = wrap(c[0][j]), b = wrap(c[1][j]);
    if (std::abs(a + b) > 1e-6 || std::abs(a) < 1e-6) continue;  // not the tilting axis, or at 0
    return (a > 0) == positive ? 0u : 1u;
  }
  return std::nullopt;
}


/// Under [machine] ik_branch = "nearest-in-travel": of the closed-form orientation solutions, each
/// rotary joint at its turn within travel nearest `start` (the distance is a sum over the joints,
/// so each joint's nearest turn gives the nearest combination), the one nearest `start` over the
/// rotary joints (the linear joints are solved afterwards). Nullopt when none lies in travel;
/// `outside` is then a rotary joint with no turn in travel on the solution nearest `start`.
std::optional<kin::JointVector> branch_in_travel(const kin::Model& model, const std::vector<kin::JointVector>& c,
                                                 const kin::JointVector& start, int& outside) {
  std::optional<kin::JointVector> best;
  double best_d = std::numeric_limits<double>::infinity(), nearest_d = best_d;
  outside = -1;
  for (const kin::JointVector& candidate : c) {
    kin::JointVector q = candidate;
    double d = 0, d_as_is = 0;
    int missing = -1;
    for (int j = 0; j < model.joint_count(); ++j) {
      const kin::Joint& jt = model.joints()[static_cast<std::size_t>(j)];
      if (jt.type != kin::JointType::rotary) continue;
      d_as_is += (candidate[j] - start[j]) * (candidate[j] - start[j]);
      if (std::isfinite(jt.min) && std::isfinite(jt.max) && jt.max - jt.min < 3600) {
        // Turns k with min ≤ c + 360k ≤ max; the one nearest start (ties: the lower turn).
        const double k_lo = std::ceil((jt.min - 1e-9 - candidate[j]) / 360.0);
        const double k_hi = std::floor((jt.max + 1e-9 - candidate[j]) / 360.0);
        if (k_lo > k_hi) {
          if (missing < 0) missing = j;
          continue;
        }
        const double k = std::clamp(std::ceil((start[j] - candidate[j]) / 360.0 - 0.5), k_lo, k_hi);
        q[j] = candidate[j] + 360.0 * k;
      } else if (candidate[j] < jt.min - 1e-9 || candidate[j] > jt.max + 1e-9) {
        if (missing < 0) missing = j;
        continue;
      }
      d += (q[j] - start[j]) * (q[j] - start[j]);
    }
    if (d_as_is < nearest_d) {
      nearest_d = d_as_is;
      outside = missing;
    }
    if (missing < 0 && d < best_d) {
      best_d = d;
      best = q;
    }
  }
  return best;
}


/// The exact inverse (tool tip and tool axis matched) is taken while no rotary joint moves more than
/// this fraction of the allowed rotary correction c; from there to c the damping of the bounded
/// solve is blended in (smoothstep of the exact correction), so the joints are a continuous
/// function of the pose across the switch, and from c on it is whole (correction ≤ c).
constexpr double kExactShare = 0.25;
/// Convergence of the remap's iterations: far below any output decimal, above the floating-point
/// noise of positions in the metres (1e-11 mm is not reachable at C = 2430°).
constexpr double kToleranceMm = 1e-9;
constexpr double kToleranceRad = 1e-11;

}  // namespace

kin::Solve solve_linear(const kin::Model& model, const Eigen::Vector3d& target, kin::JointVector& q) {
  const int n = model.joint_count();
  kin::Solve s;
  for (int it = 0; it < 20; ++it) {
    kin::Pose at;
    if (s = model.forward(q, at); !s.ok()) return s;
    const Eigen::Vector3d r = target - at.p;
    s.iterations = it;
    s.residual_mm = r.norm();
    if (s.residual_mm < kToleranceMm) return s;
    const kin::Jacobian jf = model.jacobian(q);
    Eigen::Matrix<double, 3, Eigen::Dynamic, Eigen::ColMajor, 3, kin::kMaxJoints> a(3, n);
    a.setZero();
    for (int j = 0; j < n; ++j)
      if (model.joints()[static_cast<std::size_t>(j)].type == kin::JointType::linear) a.col(j) = jf.block<3, 1>(0, j);
    const kin::JointVector dq = a.completeOrthogonalDecomposition().solve(r);
    q += dq;
  }
  s.status = kin::Status::no_convergence;
  return s;
}

ProgramMap::ProgramMap(const machine::Machine& m, kin::ModelPtr nominal, kin::ModelPtr actual, Form form,
                       const gcode::AxisVector& offset, bool length_on_z, double tool_length)
    : m_(&m), nominal_(std::move(nominal)), actual_(std::move(actual)), form_(form), offset_(offset) {
  axis_of_joint_.fill(-1);
  joint_of_axis_.fill(-1);
  for (int j = 0; j < nominal_->joint_count(); ++j) {
    const std::string& n = nominal_->joints()[static_cast<std::size_t>(j)].name;
    const int a = n.size() == 1 ? gcode::axis_index(n[0]) : -1;
    // Parallel machines: their joints are not program axes even where named X/Y (the program
    // carries the tool tip), so only serial axis programs map letters to joints directly.
    if (a >= 0 && (form == Form::axes || form == Form::tcp_rotary || form == Form::turning) && m.model_kind == "serial") {
      axis_of_joint_[static_cast<std::size_t>(j)] = a;
      joint_of_axis_[static_cast<std::size_t>(a)] = j;
    }
  }
  if (length_on_z) length_z_ = tool_length;
  hex_nominal_ = dynamic_cast<const kin::Hexapod*>(nominal_.get());
  hex_actual_ = dynamic_cast<const kin::Hexapod*>(actual_.get());
  if (form == Form::turning) spindle_joint_ = joint_of_axis_[static_cast<std::size_t>(m.turning_spindle_axis)];
}

kin::Pose ProgramMap::as_cut(const kin::Model& model, const kin::JointVector& q, const kin::Pose& p) const {
  if (form_ != Form::turning) return p;
  // The part spins about the machine's real spindle axis: the tip traces a circle as the spindle
  // turns (three angles give it), whose radius and axial place are what the part sees. In the
  // cylindrical frame (radial, tangential, axial) the tool orientation is what it cuts with.
  std::array<Eigen::Vector3d, 3> t;
  for (int k = 0; k < 3; ++k) {
    kin::JointVector qk = q;
    qk[spindle_joint_] += 120.0 * k;
    kin::Pose pk;
    if (!model.forward(qk, pk).ok()) return p;
    t[static_cast<std::size_t>(k)] = pk.p;
  }
  const Eigen::Vector3d u = t[1] - t[0], v = t[2] - t[0];
  Eigen::Vector3d n = u.cross(v);
  Eigen::Vector3d centre;
  if (n.norm() < 1e-18) {  // the tip on the axis: the axis is the workpiece Z through the tip
    n = Eigen::Vector3d::UnitZ();
    centre = p.p;
  } else {
    n.normalize();
    if (n.z() < 0) n = -n;
    // Circumcentre of the three points.
    const Eigen::Vector3d w = u.cross(v);
    centre = t[0] + (u.squaredNorm() * v.cross(w) + v.squaredNorm() * w.cross(u)) / (2 * w.squaredNorm());
  }
  const Eigen::Vector3d d = p.p - centre;
  Eigen::Vector3d er = d - d.dot(n) * n;
  const double radius = er.norm();
  if (radius > 1e-12) er /= radius;
  else er = (p.axis() - p.axis().dot(n) * n).norm() > 1e-12 ? (p.axis() - p.axis().dot(n) * n).normalized()
                                                           : n.unitOrthogonal();
  Eigen::Matrix3d frame;  // rows: radial, tangential, axial
  frame.row(0) = er.transpose();
  frame.row(1) = n.cross(er).transpose();
  frame.row(2) = n.transpose();
  kin::Pose out;
  out.p = Eigen::Vector3d(radius, 0, centre.dot(n) + d.dot(n));
  out.r = frame * p.r;
  return out;
}

kin::Solve ProgramMap::solve_turning(const kin::Pose& want, kin::JointVector& q) const {
  const int n = actual_->joint_count();
  // The tip's (radius, Z) residual at joints x, about the real spindle axis.
  const auto residual = [&](const kin::JointVector& x, Eigen::Vector2d& f) -> kin::Solve {
    kin::Pose at;
    if (kin::Solve s = actual_->forward(x, at); !s.ok()) return s;
    const kin::Pose cut = as_cut(*actual_, x, at);
    f = Eigen::Vector2d(want.p.x() - cut.p.x(), want.p.z() - cut.p.z());
    return {};
  };
  Eigen::Vector2d f;
  if (kin::Solve s = residual(q, f); !s.ok()) return s;
  kin::Solve s;
  for (int it = 0; it < 60; ++it) {
    s.iterations = it;
    s.residual_mm = f.norm();
    if (s.residual_mm < kToleranceMm) return s;
    // Jacobian of (radius, Z) over the linear joints by central differences (1 µm).
    Eigen::Matrix<double, 2, Eigen::Dynamic, Eigen::ColMajor, 2, kin::kMaxJoints> a(2, n);
    a.setZero();
    for (int j = 0; j < n; ++j) {
      if (actual_->joints()[static_cast<std::size_t>(j)].type != kin::JointType::linear) continue;
      kin::JointVector qp = q, qm = q;
      qp[j] += 1e-3;
      qm[j] -= 1e-3;
      Eigen::Vector2d fp, fm;
      if (!residual(qp, fp).ok() || !residual(qm, fm).ok()) return {kin::Status::diverged};
      a.col(j) = -(fp - fm) / 2e-3;
    }
    const kin::JointVector dq = a.completeOrthogonalDecomposition().solve(f);
    // Step halving on |residual|: below the smallest radius the machine reaches (a centre-height
    // error: the tool passes the axis at a distance) the radius is not smooth in X and full
    // Newton steps jump across the closest approach; the least-squares point is that approach.
    bool taken = false;
    for (double alpha = 1; alpha > 1e-6; alpha *= 0.5) {
      kin::JointVector qt = q + alpha * dq;
      Eigen::Vector2d ft;
      if (!residual(qt, ft).ok() || !(ft.norm() < f.norm())) continue;
      q = qt;
      f = ft;
      taken = true;
      break;
    }
    if (!taken) {  // the closest the machine comes: written there (the caller reports the distance)
      s.residual_mm = f.norm();
      return s;
    }
  }
  s.residual_mm = f.norm();
  if (!(s.residual_mm < 1e-6)) s.status = kin::Status::no_convergence;
  return s;
}

kin::Pose ProgramMap::target_of(const Command& cmd) const {
  kin::Pose p;
  p.p = cmd.c.head<3>() + offset_.head<3>();
  Eigen::Vector3d o = cmd.vector;
  if (form_ == Form::tcp_virtual) o = virtual_ab_axis(cmd.c[3] + offset_[3], cmd.c[4] + offset_[4]);
  o.normalize();
  const Eigen::Vector3d x = o.unitOrthogonal();
  p.r.col(0) = x;
  p.r.col(1) = o.cross(x);
  p.r.col(2) = o;
  return p;
}

kin::Solve ProgramMap::joints(const Command& cmd, const kin::JointVector& start, kin::JointVector& q) const {
  const int n = nominal_->joint_count();
  q = start;
  last_reached_valid_ = false;
  if (form_ == Form::axes || form_ == Form::turning) {
    for (int j = 0; j < n; ++j) {
      const int a = axis_of_joint_[static_cast<std::size_t>(j)];
      if (a < 0) continue;
      q[j] = j == spindle_joint_ ? 0.0 : cmd.c[a] + offset_[a] + (a == 2 ? length_z_ : 0.0);
    }
    return {};
  }
  kin::Pose target = target_of(cmd);
  kin::JointVector seed = start;
  if (form_ == Form::tcp_rotary) {
    // The rotary values are commanded as such; the controller solves the linear axes so that the
    // nominal tool tip is at P with the tool axis those rotary values give.
    for (int j = 0; j < n; ++j) {
      const int a = axis_of_joint_[static_cast<std::size_t>(j)];
      if (a >= 3 && a <= 5) seed[j] = cmd.c[a] + offset_[a];
    }
    // Only the linear joints move: the orientation is what the rotary values give, and is
    // singular to solve for at e.g. B = 0.
    q = seed;
    return solve_linear(*nominal_, target.p, q);
  } else if (const auto* serial = dynamic_cast<const kin::SerialModel*>(nominal_.get())) {
    // A tool vector: seed with the closed-form orientation branch the controller takes ([machine]
    // ik_branch): the one nearest the previous joints, or the one whose tilting axis has the sign
    // the controller keeps.
    kin::Pose at;
    const bool by_sign = m_->ik_branch == IkBranch::tilt_positive || m_->ik_branch == IkBranch::tilt_negative;
    if (m_->ik_branch == IkBranch::nearest_in_travel) {
      // Every solution is a candidate (the nearest may be outside the travel, the other not).
      const std::vector<kin::JointVector> candidates = serial->orientation_candidates(target.axis(), start);
      int outside = -1;
      if (const auto in = branch_in_travel(*nominal_, candidates, start, outside)) {
        seed = *in;
      } else if (!candidates.empty()) {
        kin::Solve s;
        s.status = kin::Status::out_of_limits;
        s.joint = outside;
        return s;
      }
    } else if (by_sign ||
               (nominal_->forward(seed, at).ok() && at.axis().dot(target.axis()) < std::cos(10 * kin::kDeg))) {
      const std::vector<kin::JointVector> candidates = serial->orientation_candidates(target.axis(), start);
      const std::optional<std::size_t> signed_branch =
          by_sign ? branch_by_tilt_sign(*nominal_, candidates, m_->ik_branch == IkBranch::tilt_positive) : std::nullopt;
      if (signed_branch) {
        seed = candidates[*signed_branch];
      } else if (!by_sign || !nominal_->forward(seed, at).ok() ||
                 at.axis().dot(target.axis()) < std::cos(10 * kin::kDeg)) {
        double best = std::numeric_limits<double>::infinity();
        for (const kin::JointVector& c : candidates) {
          const double d = (c - start).squaredNorm();
          if (d < best) {
            best = d;
            seed = c;
          }
        }
      }
    }
  }
  kin::IkOptions opt;
  opt.check_limits = false;
  opt.tolerance_mm = kToleranceMm;
  opt.tolerance_rad = kToleranceRad;
  if (hex_nominal_ != nullptr) {
    // The struts of the whole pose the spin rule gives (the same struts as from the target).
    // Point + axis (the spin rule): the rule's orientation of the start struts, once per block.
    if (!origin_known_ || origin_start_.size() != seed.size() || origin_start_ != seed) {
      origin_ = hex_nominal_->spin_origin_for(target, seed);
      origin_start_ = seed;
      origin_known_ = true;
    }
    last_origin_ = origin_;
    last_reached_ = target;
    last_reached_.r = kin::Hexapod::swing(origin_, target.axis());
    last_reached_valid_ = true;
    opt.match = kin::PoseMatch::full;
    return nominal_->inverse(last_reached_, seed, q, opt);
  }
  const kin::Solve s = nominal_->inverse(target, seed, q, opt);
  if (s.status == kin::Status::singular) {
    // At a pole (the tool axis on the axis of the last rotary joint, e.g. B0 on a B/C trunnion)
    // the other rotary axis is free: the controller holds it where it stands. Where the seed's
    // rotary joints, or the closed-form orientation solution nearest them (B to 0, C held), give
    // the commanded tool axis, only the linear joints move.
    std::vector<kin::JointVector> seeds{seed};
    if (const auto* serial = dynamic_cast<const kin::SerialModel*>(nominal_.get()))
      for (const kin::JointVector& c : serial->orientation_candidates(target.axis(), seed)) seeds.push_back(c);
    for (const kin::JointVector& sd : seeds) {
      kin::Pose at;
      if (!nominal_->forward(sd, at).ok() || (at.axis() - target.axis()).norm() >= kToleranceRad) continue;
      q = sd;
      if (const kin::Solve lin = solve_linear(*nominal_, target.p, q); lin.ok()) return lin;
    }
    q = start;
  }
  return s;
}

std::string ProgramMap::explain(const kin::Solve& s) const {
  if (s.status == kin::Status::out_of_limits && s.joint >= 0 && s.joint < nominal_->joint_count()) {
    const kin::Joint& jt = nominal_->joints()[static_cast<std::size_t>(s.joint)];
    return fmt::format("no solution of the programmed tool axis puts joint {} within its travel {} … {} deg; "
                       "under [machine] ik_branch = \"{}\" the controller stops here (change the tool axis or "
                       "the set-up)",
                       jt.name, jt.min, jt.max, to_string(m_->ik_branch));
  }
  return fmt::format("{}, {} iterations, residual {:.3g} mm / {:.3g} rad", kin::to_string(s.status), s.iterations,
                     s.residual_mm, s.residual_rad);
}

kin::Solve ProgramMap::command(const kin::JointVector& q, const Command& like, Command& out) const {
  return command_near(q, like, out, nullptr);
}

kin::Solve ProgramMap::actual_forward(const kin::JointVector& q, const kin::Pose& near, kin::Pose& p) const {
  if (hex_actual_ != nullptr)
    if (kin::Solve s = hex_actual_->forward(q, p, near); s.ok()) return s;
  return actual_->forward(q, p);
}

kin::Solve ProgramMap::command_near(const kin::JointVector& q, const Command& like, Command& out,
                                    const kin::Pose* near) const {
  out = like;
  if (form_ == Form::axes || form_ == Form::turning) {
    for (int j = 0; j < nominal_->joint_count(); ++j) {
      const int a = axis_of_joint_[static_cast<std::size_t>(j)];
      if (a >= 0 && j != spindle_joint_) out.c[a] = q[j] - offset_[a] - (a == 2 ? length_z_ : 0.0);
    }
    return {};
  }
  kin::Pose p;
  kin::Solve fk;
  if (near != nullptr && hex_nominal_ != nullptr) fk = hex_nominal_->forward(q, p, *near);
  if (near == nullptr || hex_nominal_ == nullptr || !fk.ok()) fk = nominal_->forward(q, p);
  if (!fk.ok()) return fk;
  out.c.head<3>() = p.p - offset_.head<3>();
  if (form_ == Form::tcp_rotary) {
    for (int j = 0; j < nominal_->joint_count(); ++j) {
      const int a = axis_of_joint_[static_cast<std::size_t>(j)];
      if (a >= 3 && a <= 5) out.c[a] = q[j] - offset_[a];
    }
  } else if (form_ == Form::tcp_vector) {
    out.vector = p.axis();
  } else {
    const Eigen::Vector2d ab = virtual_ab_angles(p.axis());
    out.c[3] = ab[0] - offset_[3];
    out.c[4] = ab[1] - offset_[4];
  }
  return {};
}

kin::Solve ProgramMap::intended(const Command& cmd, const kin::JointVector& start, kin::Pose& p,
                                kin::JointVector& q) const {
  if (auto s = joints(cmd, start, q); !s.ok()) return s;
  if (last_reached_valid_) {  // the nominal struts are those of this pose exactly
    p = last_reached_;
    return {};
  }
  return nominal_->forward(q, p);
}

kin::Solve ProgramMap::real(const Command& cmd, const kin::JointVector& start, kin::Pose& p, kin::JointVector& q) const {
  if (auto s = joints(cmd, start, q); !s.ok()) return s;
  if (last_reached_valid_) return actual_forward(q, last_reached_, p);
  return actual_->forward(q, p);
}

kin::Solve ProgramMap::hexapod_spin_consistent(const kin::Hexapod& nominal, const kin::Pose& goal,
                                                const kin::JointVector& start, const kin::JointVector& q_nom,
                                                kin::JointVector& q) const {
  // A vector block fixes the tool tip and axis; the controller picks the rotation about the axis by
  // its spin rule, on its nominal model, from the written block. The real machine must put its
  // tip and axis at the goal (its own spin is free: ψ below) while the written block, read by
  // the controller's rule, gives exactly the struts q(ψ). So solve for ψ the one equation
  // spin_of(nominal FK(q(ψ)), origin) = 0, q(ψ) the actual model's closed-form inverse of (P, R(ψ)) —
  // f(ψ) ≈ ψ + const, so the secant method converges in a few steps.
  const Eigen::Vector3d o = goal.axis();
  kin::IkOptions full;
  full.match = kin::PoseMatch::full;
  full.check_limits = false;
  kin::Pose seen = goal;
  // The controller's rule, once per block: intended() (correct() called it with this start) has it.
  const Eigen::Matrix3d origin = last_reached_valid_ ? last_origin_ : nominal.spin_origin(start, goal);
  const auto spin_error = [&](double psi, kin::JointVector& qq, double& f) -> kin::Solve {
    kin::Pose want = goal;
    want.r = Eigen::AngleAxisd(psi, o).toRotationMatrix() * goal.r;
    if (auto s = actual_->inverse(want, q_nom, qq, full); !s.ok()) return s;
    kin::Pose p;
    if (auto s = nominal.forward(qq, p, seen); !s.ok()) return s;
    seen = p;
    f = kin::Hexapod::spin_of(p, origin);
    return {};
  };
  double psi0 = 0, f0 = 0;
  if (auto s = spin_error(psi0, q, f0); !s.ok()) return s;
  double psi1 = -f0, f1 = f0;
  kin::JointVector q1;
  for (int it = 0; it < 20 && std::abs(f0) > kToleranceRad; ++it) {
    if (auto s = spin_error(psi1, q1, f1); !s.ok()) return s;
    const double slope = (f1 - f0) / (psi1 - psi0);
    psi0 = psi1;
    f0 = f1;
    q = q1;
    if (!(std::abs(slope) > 0.1) || !std::isfinite(slope)) break;  // f(ψ) ≈ ψ + c: never near 0
    psi1 = psi0 - f0 / slope;
  }
  kin::Solve s;
  s.residual_rad = std::abs(f0);
  if (!(std::abs(f0) <= 1e3 * kToleranceRad)) s.status = kin::Status::no_convergence;
  return s;
}

kin::Solve ProgramMap::correct(const Command& cmd, const kin::JointVector& start, Command& out,
                               kin::JointVector& q_actual) const {
  kin::Pose& goal = last_goal_;
  kin::JointVector& q_nom = last_q_nom_;
  last_bounded_residual_rad_ = 0;
  if (auto s = intended(cmd, start, goal, q_nom); !s.ok()) return s;
  kin::IkOptions opt;
  opt.check_limits = false;
  opt.tolerance_mm = kToleranceMm;
  opt.tolerance_rad = kToleranceRad;
  if (const auto* hex = dynamic_cast<const kin::Hexapod*>(nominal_.get()); hex != nullptr && form_ == Form::tcp_vector) {
    if (auto s = hexapod_spin_consistent(*hex, goal, start, q_nom, q_actual); !s.ok()) return s;
    return command_near(q_actual, cmd, out, &goal);
  }
  if (form_ == Form::turning) {
    // The spinning part sees the radius and Z of the tip: the linear axes set them, the rotary
    // ones keep their values (the spindle's is no position, a B head's stays as programmed).
    last_goal_cut_ = as_cut(*nominal_, q_nom, goal);
    q_actual = q_nom;
    if (auto s = solve_turning(last_goal_cut_, q_actual); !s.ok()) return s;
    return command(q_actual, cmd, out);
  }
  // Serial machines with fewer than five joints (3-axis, lathes) can only match what they have.
  kin::Solve s = actual_->inverse(goal, q_nom, q_actual, opt);
  if (m_->model_kind == "serial") {
    const double c_deg = m_->max_rotary_correction_rad / kin::kDeg;
    double largest = s.ok() ? 0.0 : std::numeric_limits<double>::infinity();  // rotary correction, degrees
    for (int j = 0; j < actual_->joint_count() && s.ok(); ++j)
      if (actual_->joints()[static_cast<std::size_t>(j)].type == kin::JointType::rotary)
        largest = std::max(largest, std::abs(q_actual[j] - q_nom[j]));
    if (largest > kExactShare * c_deg) {
      // Near a singular pose (or on a machine with fewer joints than tip + axis): the tip exactly,
      // the tool axis as far as the allowed rotary correction reaches.
      const double t = std::min(1.0, (largest - kExactShare * c_deg) / ((1 - kExactShare) * c_deg));
      kin::BoundedIkOptions b;
      b.max_rotary_correction_rad = m_->max_rotary_correction_rad;
      b.damping_share = t * t * (3 - 2 * t);
      b.tolerance_mm = kToleranceMm;
      s = kin::bounded_inverse(*actual_, goal, q_nom, q_actual, b);
      if (s.ok()) last_bounded_residual_rad_ = s.residual_rad;
    }
  }
  if (!s.ok()) return s;
  const kin::Solve written = command(q_actual, cmd, out);
  if (!written.ok() || form_ != Form::tcp_vector || m_->ik_branch == IkBranch::nearest || hex_nominal_ != nullptr)
    return written;
  // Under a sign rule ([machine] ik_branch) the controller solves the written tool axis itself:
  // near the pole a corrected axis can lie on the other branch (the tilting axis' sign flips and
  // the table turns half a turn). Then the rotary joints keep the intended pose's values and the
  // linear joints correct the tool tip; the tool axis keeps its error (reported as limited).
  kin::JointVector q_rule;
  if (joints(out, start, q_rule).ok() && (q_rule - q_actual).cwiseAbs().maxCoeff() < 1e-6) return written;
  q_actual = q_nom;
  if (const kin::Solve lin = solve_linear(*actual_, goal.p, q_actual); !lin.ok()) return lin;
  kin::Pose at;
  if (actual_->forward(q_actual, at).ok())
    last_bounded_residual_rad_ = std::acos(std::clamp(at.axis().dot(goal.axis()), -1.0, 1.0));
  return command(q_actual, cmd, out);
}

gcode::AxisMask written_axes(const machine::Machine& m, Form f) {
  gcode::AxisMask mask = 0;
  if (f == Form::axes || f == Form::tcp_rotary) {
    // Under TCP with rotary axes the block carries the tool tip (X Y Z) and the rotary values.
    for (int a = 0; a < gcode::kAxisCount; ++a)
      if (m.joint_of_axis[static_cast<std::size_t>(a)] >= 0 && (f == Form::axes || a < 3 || gcode::is_rotary(a)))
        mask |= static_cast<gcode::AxisMask>(1u << a);
  } else if (f == Form::turning) {
    // Turning: the linear axes set the tip's radius and Z; rotary values stay as programmed.
    for (int a = 0; a < 3; ++a)
      if (m.joint_of_axis[static_cast<std::size_t>(a)] >= 0) mask |= static_cast<gcode::AxisMask>(1u << a);
  } else {
    mask = 0b111;
    if (f == Form::tcp_virtual) mask |= 0b11000;
  }
  return mask;
}

ToolLengthModels::ToolLengthModels(const machine::Machine& m) : m_(m) {
  const int in = m.nominal->parameter_index("tool.length");
  const int ia = m.actual->parameter_index("tool.length");
  if (in >= 0 && ia >= 0)
    deviation_ = m.actual->values()[static_cast<std::size_t>(ia)] - m.nominal->values()[static_cast<std::size_t>(in)];
}

const std::pair<kin::ModelPtr, kin::ModelPtr>& ToolLengthModels::with_tool_length(double mm) {
  auto it = cache_.find(mm);
  if (it != cache_.end()) return it->second;
  auto set = [](const kin::ModelPtr& model, double length) -> kin::ModelPtr {
    const int i = model->parameter_index("tool.length");
    if (i < 0) return model;
    std::vector<double> v = model->values();
    if (v[static_cast<std::size_t>(i)] == length) return model;  // the machine file's tool: m.actual itself
    v[static_cast<std::size_t>(i)] = length;
    return model->with_values(std::move(v));
  };
  // The [tool] length's tool: m.actual as it is (its "tool.length" is mm + deviation_ exactly).
  kin::ModelPtr act = std::abs(mm - m_.tool_length) <= 1e-9 ? m_.actual : set(m_.actual, mm + deviation_);
  return cache_.emplace(mm, std::make_pair(set(m_.nominal, mm), std::move(act))).first->second;
}

std::string ToolLengthModels::unknown_length_error(double mm, std::uint32_t h) const {
  return fmt::format(
      "machine file {} calibrates the tool length ([errors] \"tool.length\" = {:.6f} mm for the tool of [tool] length "
      "{} mm), but this block runs with tool length {} mm{}, whose length error the file does not give; compensate "
      "with a machine file calibrated for this tool, or make [tool] length this tool's",
      m_.file, m_.tool_length + deviation_, m_.tool_length, mm, h != 0 ? fmt::format(" (H{})", h) : std::string());
}

std::optional<ProgramMap> map_of(const machine::Machine& m, ToolLengthModels& models, const gcode::Motion& mo) {
  const auto offset = program_offset(m, mo);
  if (!offset) return std::nullopt;
  const auto tool = machine::tool_length_of(m, mo);
  if (!tool) return std::nullopt;
  const double length = *tool;
  if (!models.length_error_known(length)) return std::nullopt;
  const Form f = form_of(m, mo);
  const auto& [nom, act] = models.with_tool_length(length);
  return ProgramMap(m, nom, act, f, *offset, f == Form::axes && mo.tool_length_active, length);
}

}  // namespace postproc::machine
