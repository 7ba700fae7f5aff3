#pragma once
/// @file
/// Identification of the 33 error parameters of the 3-PRS hybrid machine (document 001) from
/// measured tool poses, by Levenberg–Marquardt (Ceres) on the model's analytic identification
/// Jacobian.
///
/// Residuals, per pose, all in "mm-equivalent":
/// - position: measured P − model P (mm, workpiece frame);
/// - orientation, 6-DoF data: kOrientationWeight · rotation_difference(measured R, model R)
///   (rad → mm-equivalent);
/// - orientation, 5-DoF data (has_torsion = false): kOrientationWeight · (u·(O_m − O), v·(O_m − O))
///   with u, v an orthonormal pair orthogonal to the measured tool axis O_m — the two components
///   of the axis error; the measured rotation about O_m is ignored.
/// kOrientationWeight = 180/π mm/rad, so an angle error of 0.01° weighs as much as 0.01 mm: the
/// inverse ratio of the noise levels of document 001 (±0.01 mm, ±0.01°).

#include <span>
#include <string>
#include <vector>

#include "postproc/kinematics/model.hpp"
#include "postproc/kinematics/prs_hybrid.hpp"

namespace postproc::cal {

/// mm-equivalent per rad of orientation residual: 0.01° ↔ 0.01 mm.
inline constexpr double kOrientationWeight = 180.0 / kin::kPi;

/// One measured pose: the commanded joint values and the pose the machine reached.
struct PoseMeasurement {
  kin::JointVector q;          ///< joint values sent to the machine (mm)
  kin::Pose measured;          ///< measured tool pose, workpiece frame
  bool has_torsion = true;     ///< false: 5-DoF, the rotation about the tool axis is not measured
};

enum class Method {
  /// Plain LM (Ceres's adaptive damping); 5-DoF poses contribute their 5 components (the
  /// torsion-only parameter combinations are then unobserved and stay near the start under LM's
  /// damping).
  least_squares,
  /// Document 001's ridge estimate: every step solves (JᵀJ + μI) dr = −Jᵀf with μ ≥ λ — λ‖dr‖²
  /// added to each step's linearised cost, a Tikhonov prior on the increment. Done in Ceres by
  /// fixing the LM diagonal to I (min/max_lm_diagonal = 1) and capping the trust region at 1/λ.
  ridge,
  /// Document 001's improved method: at every residual evaluation the unmeasured torsion of each
  /// 5-DoF measurement is replaced by the model's own at the current parameters (the smallest
  /// rotation carrying the model's tool axis onto the measured one, applied to the model's
  /// orientation), so the 6-row residual has dψ = 0, and the full 6-row Jacobian is used: plain
  /// least squares on 6-DoF rows. Its fixed point is the 5-component least-squares solution.
  psi_substitution,
};

struct IdentifyOptions {
  Method method = Method::least_squares;
  /// Ridge weight λ (mm² per unit² of parameter). ≤ 0: chosen automatically by generalized
  /// cross-validation on the weighted, linearised problem at the start model
  /// (minimise n‖(I − A_λ)b‖² / tr(I − A_λ)², A_λ the ridge hat matrix, λ over 1e-12…1e2).
  double ridge_lambda = 0;
  /// Cap on Ceres LM iterations. Every method is a single Ceres solve.
  int max_iterations = 150;
  /// Error-parameter indices (0…32) held at the start model's values.
  std::vector<int> fixed;
};

struct IdentifyResult {
  std::vector<double> values;   ///< the 33 identified errors (parameter order, mm / rad)
  int iterations = 0;           ///< Ceres LM iterations (successful and rejected steps)
  double seconds = 0;           ///< wall time of identify()
  double initial_cost = 0;      ///< ½‖res‖² of the measurements' own components at the start (mm²)
  double final_cost = 0;        ///< the same at the result
  double lambda = 0;            ///< the ridge λ used (0 for other methods)
  bool usable = false;          ///< ceres::Solver::Summary::IsSolutionUsable of every solve
  std::string message;          ///< ceres::Solver::Summary::message
};

/// Identifies the 33 error parameters starting from start_model's errors. Throws postproc::Error
/// (usage) for an empty measurement set, a bad fixed index, or a pose the start model cannot reach.
[[nodiscard]] IdentifyResult identify(const kin::PrsHybrid& start_model, std::span<const PoseMeasurement> data,
                                      const IdentifyOptions& options = {});

/// The residual vector of the measurements against a model with these errors (5 or 6 rows per
/// pose, as described in the file comment, mm-equivalent). For tests and reports.
[[nodiscard]] Eigen::VectorXd pose_residuals(const kin::PrsHybrid& model, std::span<const PoseMeasurement> data);

/// Document 001's simulation experiment (section 3), for the tests and the bench.
namespace doc001 {

/// Target in the workpiece frame: tool tip at base height z (mm), tilt θ toward direction φ
/// (rad), no torsion, X = Y = 0 offset (x, y mm). The workpiece frame is the base frame turned by
/// π about X (see prs_hybrid.hpp).
[[nodiscard]] kin::Pose target(double z, double theta, double phi, double x = 0, double y = 0);

/// The 27 measuring poses (z, φ, θ): on each plane z = 700, 800, 900 mm, θ = 0 and θ = 40° at
/// φ = 0°, 45°, …, 315°. The paper shows its pose pattern only in a figure (fig. 5); this is our
/// reading. (Mixing θ = 20° and 40° instead leaves the dq − dl combinations badly conditioned and
/// the error after identification at 0.02–0.3 mm depending on the noise draw.)
[[nodiscard]] std::vector<kin::Pose> pose_set();

/// Simulated measurements: joints from `controller`'s nominal closed-form inverse (what the
/// controller commands), pose from `truth`'s forward kinematics plus uniform noise: ±noise_mm per
/// position component and a small rotation with components uniform in ±noise_deg (workpiece
/// frame). has_torsion as given (5-DoF data keep the noisy rotation; identify ignores its torsion).
[[nodiscard]] std::vector<PoseMeasurement> simulate(const kin::PrsHybrid& controller, const kin::PrsHybrid& truth,
                                                    std::span<const kin::Pose> targets, unsigned seed,
                                                    bool has_torsion, double noise_mm = 0.01, double noise_deg = 0.01);

/// Largest tool-tip error (mm) on the z = 700 mm plane over θ = 0…40° (1° steps) and φ in 5°
/// steps: joints from `commanding.inverse` (its own errors; the closed form for a nominal model),
/// tip from `truth.forward`. Infinity if a pose cannot be commanded or reached.
[[nodiscard]] double max_tip_error_z700(const kin::PrsHybrid& commanding, const kin::PrsHybrid& truth);

}  // namespace doc001

}  // namespace postproc::cal
