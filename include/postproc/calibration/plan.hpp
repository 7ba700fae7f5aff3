#pragma once
/// @file
/// Planning a calibration (issue 5, `postproc calibrate plan` / `calibrate simulate`): which
/// joint configurations to measure, simulated measurements at them, and the NC program that
/// visits them.
///
/// Planning is greedy D-optimal design over random candidates: every candidate contributes the
/// rows of its identification Jacobian (identify.hpp's linearise() at the model's own prediction,
/// so the residual is 0), columns scaled by their norms over all candidates (units do not matter);
/// the pose that most increases log det(JᵀJ + εI) is added until N are chosen. Fedorov exchange
/// passes then swap a chosen pose for a candidate while that increases the column-normalised
/// criterion log det(M) − Σ log M_cc (M = JᵀJ + εI of the chosen set): the determinant of the
/// information with every column scaled by its norm over the chosen set, i.e. analyse()'s O1
/// (2r·log(O1·√rows) up to ε). The greedy criterion alone favours large column norms; the
/// exchange turns them into O1. Every candidate keeps J_i M⁻¹ J_iᵀ, updated by Woodbury's formula
/// per added or removed pose, so a step costs one (rows × parameters × 6) product.
///
/// Candidates:
/// - serial models: joint vectors uniform in each joint's [min + margin, max − margin]; a joint
///   without limits draws from ±300 mm (linear) or ±180° (rotary);
/// - parallel models (kind() names prs_hybrid or hexapod): tool poses drawn around the home pose
///   (forward kinematics at q = 0): the tool tip uniform in a box of half sizes `box_mm`
///   (workpiece frame), the tool axis uniform over the spherical cap of half angle `max_tilt_deg`
///   about the home axis, the orientation the home orientation turned by the smallest rotation
///   onto that axis (no torsion relative to home: what a 5-axis program gives a hexapod after a
///   move through the home orientation, see plan_program()); joints from the model's
///   inverse(), kept when inside the limits (with margin) and when forward() gives the pose back.

#include <cstdint>
#include <limits>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "postproc/calibration/identify.hpp"
#include "postproc/calibration/measurement.hpp"
#include "postproc/kinematics/model.hpp"
#include "postproc/machine/machine.hpp"

namespace postproc::cal {

struct PlanOptions {
  int poses = 30;                       ///< N, poses to choose
  MeasurementKind kind = MeasurementKind::pose;
  bool has_torsion = true;              ///< pose kind: 6-DoF (true) or 5-DoF (false)
  int candidates = 2000;                ///< random candidates to choose from
  std::uint64_t seed = 1;
  /// Kept inside every limited joint's travel: mm for linear joints, degrees for rotary ones.
  double margin = 0;
  /// Parameters (indices into parameters()); empty: every error parameter.
  std::vector<int> parameters;
  int exchange_passes = 3;              ///< Fedorov exchange passes after the greedy choice (0: none)
  /// Parallel models: half sizes of the tool-tip box around the home tip (mm, workpiece frame).
  Eigen::Vector3d box_mm{150, 150, 100};
  double max_tilt_deg = 20;             ///< parallel models: largest tilt from the home tool axis
  /// The working region (`calibrate plan --region-from` / `--region`): per joint [lo, hi] (mm /
  /// deg) the candidates must lie in, intersected with the travel; empty: the travel.
  std::vector<std::pair<double, double>> joint_region;
  /// Parallel models: the tool-tip box [low, high] (workpiece frame, mm) the candidate poses are
  /// drawn in, instead of home ± box_mm.
  std::optional<std::pair<Eigen::Vector3d, Eigen::Vector3d>> tip_region;
  double orientation_weight = kOrientationWeight;
  /// Ridge of the criterion, relative to the scaled information of one average candidate
  /// (keeps log det finite when some parameter combination is not identifiable at all).
  double epsilon = 1e-6;
};

struct PlanResult {
  std::vector<kin::JointVector> joints;  ///< chosen joint vectors (mm / deg), in visiting order
  std::vector<int> parameters;           ///< the columns analysed (indices into parameters())
  Identifiability planned;               ///< analyse() of the chosen set
  Identifiability random;                ///< analyse() of N random candidates, for comparison
  Identifiability all;                   ///< analyse() of every candidate: the best rank possible
  int candidates = 0;                    ///< candidates generated
  int draws = 0;                         ///< random draws needed (parallel models reject some)
  int exchanges = 0;                     ///< swaps made by the exchange passes
  /// The column-normalised criterion log det(M) − Σ log M_cc (see the file comment) after the
  /// greedy choice, of the result, and of the random set.
  double log_det_greedy = 0;
  double log_det = 0;
  double log_det_random = 0;
  double seconds = 0;                    ///< wall time of plan_poses()
};

/// Chooses `options.poses` joint configurations of `model` (use the nominal model: the one the
/// controller commands) that make the parameters best identifiable. Throws postproc::Error
/// (usage) for N < 1, fewer candidates than N, a bad parameter index, or when too few reachable
/// candidates can be drawn.
[[nodiscard]] PlanResult plan_poses(const kin::Model& model, const PlanOptions& options = {});

/// Where a set of programs works: the range of every joint the controller commands, the tool-tip
/// box (workpiece frame) and the largest tilt of the tool axis from the home axis, over every
/// motion whose position is known (through the controller's map, as compensate reads them).
struct WorkingRegion {
  std::vector<double> joint_min, joint_max;  ///< per joint, mm / deg
  Eigen::Vector3d tip_min = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d tip_max = Eigen::Vector3d::Constant(-std::numeric_limits<double>::infinity());
  double max_tilt_deg = 0;
  std::uint64_t motions = 0;  ///< motions that set the region
  std::vector<kin::JointVector> joints;  ///< the motions' joints (the first kMaxRegionJoints), mm / deg
  static constexpr std::size_t kMaxRegionJoints = 100000;
};
/// Reads `programs` (NC files in the machine's dialect) into their working region. Reports the
/// programs' own diagnostics to `sink`; throws postproc::Error (usage) when no motion is known.
[[nodiscard]] WorkingRegion program_region(const machine::Machine& m, std::span<const std::string> programs,
                                           gcode::DiagnosticSink& sink);
/// Plans in `r`: serial models draw joints in its joint ranges; parallel models draw tool tips in
/// its tip box widened by `widen_mm` on every side and tool axes up to its tilt (at least 1°),
/// and keep joints in its joint ranges widened by `widen_mm` (sliders, struts).
void plan_in(const WorkingRegion& r, const kin::Model& model, PlanOptions& o, double widen_mm = 5);

/// Measurements at joint vectors that a model predicts exactly (residual 0): pose kinds
/// measured = forward(q); struts: q recorded, measured = forward(q) (a full pose). Labels p1, p2…
/// Throws postproc::Error (usage) naming the pose where forward() fails.
[[nodiscard]] std::vector<Measurement> predicted_measurements(const kin::Model& model,
                                                              std::span<const kin::JointVector> joints,
                                                              MeasurementKind kind, bool has_torsion = true);

struct SimulateOptions {
  MeasurementKind kind = MeasurementKind::pose;
  bool has_torsion = true;   ///< pose kind: 6-DoF or 5-DoF
  /// Uniform noise: ±noise_mm on each position component (struts: on each recorded strut
  /// coordinate), and a small rotation with components uniform in ±noise_deg (workpiece frame),
  /// as document 001's simulation. Uniform ±a has standard deviation a/√3.
  double noise_mm = 0;
  double noise_deg = 0;
  /// Every validate_every-th measurement (the 5th, 10th… for 5) is held out (validate = true);
  /// 0: none.
  int validate_every = 0;
  std::uint64_t seed = 1;
};

/// Simulated measurements at the commanded joints (mm / deg), deterministic for a seed.
/// - pose, position, direction: measured = truth.forward(q) + noise (what the instrument sees);
/// - struts (document 003): the setting tool is placed at the pose the controller believes,
///   controller.forward(q); the NC records the strut coordinates the true machine needs there,
///   truth.inverse(that pose, full match), + noise; measured = that known pose.
/// Labels "p1", "p2"… Throws postproc::Error (usage) naming the pose a model cannot evaluate.
[[nodiscard]] std::vector<Measurement> simulate_measurements(const kin::Model& truth, const kin::Model& controller,
                                                             std::span<const kin::JointVector> commanded,
                                                             const SimulateOptions& options = {});

/// An NC program in the machine's dialect that visits each pose and stops (M0) for the
/// measurement "measure pose pN":
/// - axis programs: G90 G0 in G54 (work offset subtracted), every program axis of the machine
///   (joint_of_axis) with machine.decimals(axis);
/// - tool-tip programs: the nominal tool pose at q, X Y Z (tool tip − G54) plus the orientation:
///   `vector`: I J K under G43.5 (Fanuc) or A3 B3 C3 under TRAORI (Siemens), 6 decimals;
///   `virtual_ab`: A B with O = Rx(A)·Ry(B)·ẑ. For a hexapod, whose 5-axis program leaves the
///   rotation about the tool axis to the controller (the orientation nearest the previous
///   block's), each pose is preceded by a move to the home pose, so the controller commands the
///   planned torsion (the program assumes the machine starts at home).
/// Fanuc: % … %, O0001, comments in parentheses; Siemens: ';' comments. Ends with M30.
/// Throws postproc::Error (usage) when the machine's form cannot be written (e.g. a tool vector
/// in a dialect without one) or a pose cannot be evaluated.
[[nodiscard]] std::string plan_program(const machine::Machine& machine, std::span<const kin::JointVector> poses,
                                       std::string_view title);

}  // namespace postproc::cal
