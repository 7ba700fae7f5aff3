#pragma once
/// @file
/// The 5-axis hybrid machine of document 001: a 3-PRS (3P(4R)S, each parallelogram taken as one
/// link) spindle head giving z, φ, θ, carried by two serial axes X (table) and Y (head on the
/// column) that absorb the head's parasitic motions.
///
/// Frames (document 001, fig. 3):
/// - base O-XYZ: origin at the centre of the slider zero points B1 B2 B3, X along OB1, Z normal to
///   their plane toward the moving platform (and the tool tip); limb i lies in the plane through Z
///   at α_i = 2(i−1)π/3 from X (R_i = Rz(α_i));
/// - platform O'-X'Y'Z': origin at the centre of the sphere centres A1 A2 A3, X' along O'A1, Z'
///   normal to the platform toward the tool tip; its orientation is
///   R_T = Rz(φ)·Ry(θ)·Rz(−φ)·Rz(ψ), ψ the parasitic torsion (0 for the nominal machine);
/// - tool tip H = O' + R_T·(0, 0, tool length), base frame;
/// - workpiece frame W = the base frame turned by π about X (X_W = X, Y_W = −Y, Z_W = −Z), so the
///   tool axis O (tip → spindle, = −Z') is +Z_W at θ = 0, then shifted by the serial axes:
///   P_W = diag(1, −1, −1)·(H − workpiece_origin) + (X, Y, 0). X and Y are positive when the tool
///   moves toward +X_W / +Y_W relative to the workpiece (table X moves the other way physically);
///   the tool frame is (X', −Y', −Z') of the platform, expressed in W.
///
/// Error model (document 001, eq. 5; per limb, in the limb frame R_i):
///   A_i = H + R_T·(R_i·(a_i + δa_i) − L_d),  S_i = R_i·(b_i + δb_i) + (q_i + δq_i)·G_i·e_z,
///   A_i − S_i = G_i·Ry(γ_i)·R_θCi·(0, 0, l + δl_i),  G_i = R_i·R_Bi·R_θBi,
/// with a_i = (a, 0, 0), b_i = (b, 0, 0), L_d = (0, 0, tool length), R_Bi = Ry(guide tilt), γ_i the
/// free angle of the revolute joint (axis G_i·e_y) and R_θBi = Rx·Ry·Rz of three small angles.
/// Of R_θCi only its rotation about x acts on (0, 0, l) (about y it is γ_i, about z it leaves the
/// link unchanged); δb_z is left out because it duplicates δq_i along the guide. That leaves 11
/// errors per limb, 7 lengths and 4 angles, the pattern of document 001's Table 1:
///   limb<i>.da_x, .da_y, .da_z   sphere-centre offset, platform frame turned by R_i (mm)
///   limb<i>.db_x, .db_y          slider zero-point offset, base frame turned by R_i (mm)
///   limb<i>.tb_x, .tb_y, .tb_z   small rotations of the guide (and joint axis) frame (rad)
///   limb<i>.tc_x                 tilt of the link out of the joint plane (rad)
///   limb<i>.dq                   slider zero offset along the guide (mm)
///   limb<i>.dl                   link length error (mm)
/// Indices 0…32 (limb-major). After them, not error parameters (error = false): geom.a, geom.b,
/// geom.l, tool.length (mm) and geom.guide_tilt (rad) hold the nominal geometry.

#include <array>
#include <memory>
#include <span>
#include <vector>

#include "postproc/kinematics/model.hpp"

namespace postproc::kin {

/// Nominal geometry and travel of the hybrid machine (mm, rad).
struct PrsHybridGeometry {
  double base_radius = 220;      ///< b = |OB_i|, slider zero points, mm
  double platform_radius = 201;  ///< a = |O'A_i|, sphere centres, mm
  double link_length = 487;      ///< l, slider revolute axis to sphere centre, mm
  double tool_length = 150;      ///< O' to the tool tip along Z', mm
  /// Guide direction: +Z tilted by this angle toward OB_i (outward), in the limb plane, rad.
  /// Document 001 does not give it; 0 = guides parallel to Z.
  double guide_tilt = 0;
  /// The workpiece-frame origin, in the base frame (mm), at X = Y = 0.
  Eigen::Vector3d workpiece_origin = Eigen::Vector3d::Zero();
  double x_min = -1500, x_max = 1500;  ///< travel of X, mm
  double y_min = -1500, y_max = 1500;  ///< travel of Y, mm
  double q_min = -300, q_max = 700;    ///< travel of each slider from its zero point B_i, mm
};

/// The hybrid machine: joints X, Y (mm), then the sliders q1, q2, q3 (mm from B_i along the guide,
/// positive toward the platform). Immutable and thread-safe.
class PrsHybrid final : public Model {
 public:
  static constexpr int kLimbErrors = 11;                ///< error parameters per limb
  static constexpr int kErrorCount = 3 * kLimbErrors;  ///< 33
  /// 6 × 33: dP (mm) then dθ (rad), workpiece frame, per unit of each error parameter.
  using IdentificationJacobian = Eigen::Matrix<double, 6, kErrorCount>;

  /// The nominal machine (every error 0). Throws postproc::Error (usage) for a geometry that
  /// cannot be assembled (non-positive lengths, a link shorter than |b − a|).
  explicit PrsHybrid(PrsHybridGeometry g = {});

  [[nodiscard]] std::string kind() const override { return "prs_hybrid"; }
  /// Newton on the 6 loop-closure equations (length and joint-plane condition per limb), seeded
  /// from the plane through estimated sphere centres. Not ok: `unreachable` when two sliders are
  /// too far apart for their links, `diverged` when the residual grows or the iteration reaches
  /// another assembly mode, `no_convergence` at the iteration limit; `out` is then unchanged.
  [[nodiscard]] Solve forward(const JointVector& q, Pose& out) const override;
  /// Analytic: J = −(∂F/∂x)⁻¹·∂F/∂q at the forward solution (NaN columns if forward fails).
  [[nodiscard]] Jacobian jacobian(const JointVector& q) const override;
  /// point_and_axis: exact, no forward kinematics in the loop. The tilt fixes R_T up to ψ; Newton
  /// on the three joint-plane conditions in (H_x, H_y, ψ) from the nominal closed form, then X, Y
  /// from H and each slider from its link length. `start` is not needed: the machine has one
  /// working branch. full: the base-class Gauss–Newton from that solution (5 joints cannot meet 6
  /// conditions in general). residual_mm is then the largest joint-plane residual (P and O are
  /// met by construction); `unreachable` when the axis points into the head (θ ≥ 90°).
  [[nodiscard]] Solve inverse(const Pose& target, const JointVector& start, JointVector& q,
                              const IkOptions& opt = {}) const override;
  [[nodiscard]] std::shared_ptr<const Model> with_values(std::vector<double> values) const override;

  /// Closed-form inverse kinematics of the nominal geometry (errors ignored): tool-tip P and
  /// axis O (workpiece frame) → X, Y, q1…q3. `unreachable` if a link cannot reach, or the axis
  /// points away from the spindle side (θ ≥ 90°).
  [[nodiscard]] Solve nominal_inverse(const Pose& target, JointVector& q) const;
  /// The same machine with these 33 error values (mm / rad, parameter order), nominal geometry kept.
  [[nodiscard]] std::shared_ptr<const PrsHybrid> with_errors(std::span<const double> errors) const;
  /// dP/dr at joint values q: the pose change (workpiece frame) per unit of each error parameter,
  /// by implicit differentiation of the loop closure (document 001, eq. 9–10). `s` (optional)
  /// receives the forward solve; on failure the matrix is NaN.
  [[nodiscard]] IdentificationJacobian identification_jacobian(const JointVector& q, Solve* s = nullptr) const;
  /// The platform pose in the base frame from the slider values (mm): tool tip H and R_T.
  [[nodiscard]] Solve platform_forward(const Eigen::Vector3d& sliders, Eigen::Vector3d& tip, Eigen::Matrix3d& r_t) const;
  [[nodiscard]] const PrsHybridGeometry& geometry() const { return geom_; }

  /// (φ, θ, ψ) of R_T = Rz(φ)Ry(θ)Rz(−φ)Rz(ψ), rad; φ = 0 when θ = 0.
  [[nodiscard]] static Eigen::Vector3d tilt_torsion(const Eigen::Matrix3d& r_t);
  /// Rz(φ)Ry(θ)Rz(−φ) for the platform normal n = R_T·e_z (unit, n_z > −1): the tilt without torsion.
  [[nodiscard]] static Eigen::Matrix3d tilt_rotation(const Eigen::Vector3d& n);
  /// Tool pose in the workpiece frame from the platform pose in the base frame and X, Y (mm).
  [[nodiscard]] Pose to_workpiece(const Eigen::Vector3d& tip, const Eigen::Matrix3d& r_t, double x, double y) const;

 private:
  /// One limb's constants at the current parameter values (see the file comment).
  struct Limb {
    Eigen::Vector3d r;   ///< tool tip → sphere centre, platform frame: R_i(a_i + δa_i) − L_d
    Eigen::Vector3d b;   ///< slider zero point R_i(b_i + δb_i), base frame
    Eigen::Vector3d u;   ///< guide direction G_i e_z
    Eigen::Vector3d y;   ///< revolute-joint axis G_i e_y
    double lp = 0;       ///< l + δl
    double cy = 0;       ///< link component along the joint axis: −(l + δl)·sin(tc_x)
    double dq = 0;       ///< δq
  };
  PrsHybrid(PrsHybridGeometry g, std::vector<double> values);
  void build_limbs();
  /// Loop residuals (mm) and their derivative by (dH, ω), ω a small rotation in the base frame.
  void residual(const Eigen::Vector3d& sliders, const Eigen::Vector3d& tip, const Eigen::Matrix3d& r_t,
                Eigen::Matrix<double, 6, 1>& f, Eigen::Matrix<double, 6, 6>* jx) const;
  PrsHybridGeometry geom_;
  std::array<Limb, 3> limbs_{};
};

/// Document 001's nominal machine: b = 220, a = 201, l = 487, tool 150 mm, guides parallel to Z.
[[nodiscard]] std::shared_ptr<const PrsHybrid> make_document001_machine();
/// Document 001 Table 1, the 33 simulated errors in parameter order (limb-major; per limb the
/// table's 11 columns as da_x, da_y, da_z, db_x, db_y, tb_x, tb_y, tb_z, tc_x, dq, dl). The table
/// states no units or column names; the 7 large columns are read as mm and the 4 small ones as
/// angles given in degrees, converted here to rad (see the tests for how that reading was chosen).
[[nodiscard]] std::array<double, PrsHybrid::kErrorCount> document001_table1_errors();

}  // namespace postproc::kin
