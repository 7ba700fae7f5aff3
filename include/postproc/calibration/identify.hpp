#pragma once
/// @file
/// Identification of a machine model's error parameters from measurements (measurement.hpp), by
/// Levenberg–Marquardt in Ceres, with identifiability analysis (SVD / rank-revealing QR of the
/// identification Jacobian) and parameter standard deviations from the covariance.
///
/// Residuals, per measurement, measured − model, all in "mm-equivalent":
/// - position rows: measured P − model P (mm, workpiece frame);
/// - 6-DoF orientation rows: w · rotation_difference(measured R, model R) (rad → mm-equivalent);
/// - tool-axis rows (5-DoF poses, directions): w · (u·(O_m − O), v·(O_m − O)) with u, v an
///   orthonormal pair orthogonal to the measured tool axis O_m; the rotation about O_m is ignored;
/// - strut rows (hexapod, document 003): recorded strut coordinate − the model's strut coordinate
///   at the measured pose (mm; inverse kinematics, so no forward solve).
/// w = orientation_weight (default 180/π mm/rad: 0.01° weighs as much as 0.01 mm, the inverse
/// ratio of document 001's noise levels ±0.01 mm / ±0.01°).
///
/// Uncertainty (measurement.hpp Source): a file's length rows are weighted by σ₀/σ and its angle
/// rows by σ₀/σ_angle, with σ = `# sigma:` (default kDefaultSigma), σ_angle = `# sigma_angle:`
/// (default σ/w) and σ₀ the smallest σ of the fitted files, so residuals and costs stay in mm at
/// the accuracy of the best file (files without settings: weights 1 and w, as before).
///
/// Instrument frames (`# frame: instrument`): P_w = R·P_i + t, R_w = R·R_i per frame, R = exp(ω)·R₀
/// with R₀, t's start from a rigid fit (Umeyama, no scale) of the measured points (or axes) to
/// the start model's; the free components of (t, ω) are estimated jointly with the machine's
/// parameters. A machine parameter that the registration explains (its column in their span: a
/// workpiece-frame offset such as EX0C + EX0X on a trunnion) is held at the machine file's value
/// and reported: the data cannot tell it from where the instrument stood, and attributing the
/// instrument's misregistration to the machine would move every corrected block by it.
///
/// Derivatives: analytic where the model has an identification Jacobian (the 3-PRS hybrid's 33
/// errors at commanded joints; the hexapod's 42 parameters in strut space; every parameter of a
/// serial chain, SerialModel::identification_jacobian), central differences of
/// the model (with_values) for every other parameter; `numeric_derivatives` forces differences.

#include <array>
#include <optional>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "postproc/calibration/measurement.hpp"
#include "postproc/kinematics/model.hpp"
#include "postproc/kinematics/prs_hybrid.hpp"
#include "postproc/progress.hpp"

namespace postproc::cal {

/// mm-equivalent per rad of orientation residual: 0.01° ↔ 0.01 mm.
inline constexpr double kOrientationWeight = 180.0 / kin::kPi;
/// Length uncertainty of a file without `# sigma:` (mm).
inline constexpr double kDefaultSigma = 0.01;

enum class Method {
  /// Plain LM (Ceres's adaptive damping) on the measured components. The default: with the
  /// unidentifiable combinations fixed by the identifiability analysis it is well posed for every
  /// kind of data, converges in a handful of iterations and is the unbiased estimate.
  least_squares,
  /// Ridge (Tikhonov) estimate: λ‖x − x₀‖² added to the cost (x₀ the start values, parameters in
  /// mm and rad), pulling weakly observed directions toward the start. λ given, or chosen by
  /// generalized cross-validation on the linearised problem at the start (λ over 1e-12…1e2).
  /// Document 001's ridge iterates (JᵀJ + λI)Δ = −Jᵀf, whose fixed point is the plain least-squares
  /// solution reached slowly (550 iterations); the penalised form converges like LM.
  ridge,
  /// Document 001's improved method for 5-DoF poses: at every evaluation the unmeasured torsion of
  /// each 5-DoF pose is replaced by the model's own (the smallest rotation carrying the model's
  /// tool axis onto the measured one, applied to the model's orientation), so the torsion residual
  /// is 0 while the full 6-row Jacobian is used. Same fixed point as least squares on 5 rows.
  psi_substitution,
};
[[nodiscard]] std::string_view to_string(Method m);
[[nodiscard]] std::optional<Method> parse_method(std::string_view s);

enum class Loss { none, huber, cauchy };

/// How identify() minimises. `ceres`: a Ceres problem with a residual block per measurement (it
/// holds the whole Jacobian: about 4 KB per measurement). `streamed`: Levenberg–Marquardt with
/// Ceres' step rule on the Jacobian compressed as it is formed (a tall-skinny QR in chunks, on
/// `threads`): memory independent of the number of measurements; not with bounds or ψ
/// substitution. `automatic`: streamed from kStreamedRows residual components where it applies.
enum class Solver { automatic, ceres, streamed };
[[nodiscard]] std::string_view to_string(Solver s);
[[nodiscard]] std::optional<Solver> parse_solver(std::string_view s);
inline constexpr long kStreamedRows = 60000;

struct IdentifyOptions {
  Method method = Method::least_squares;
  /// Ridge weight λ (mm² per unit² of parameter). ≤ 0: chosen by GCV.
  double ridge_lambda = 0;
  /// Cap on Ceres LM iterations (one Ceres solve per identify()).
  int max_iterations = 150;
  /// Parameters to identify (indices into parameters()); empty: every error parameter.
  std::vector<int> free;
  /// Removed from the identified set, held at the start values.
  std::vector<int> fixed;
  /// Robust loss per measurement (Ceres HuberLoss / CauchyLoss) with scale loss_scale (mm-eq).
  Loss loss = Loss::none;
  double loss_scale = 0.02;
  /// Bounds on parameter values (absolute, the parameter's unit): index, lower, upper.
  std::vector<std::pair<int, std::pair<double, double>>> bounds;
  double orientation_weight = kOrientationWeight;
  bool numeric_derivatives = false;
  /// A direction of the column-scaled Jacobian with singular value below rank_tolerance·σ_max is
  /// not identifiable: one parameter per such direction (the rank-revealing QR's choice) is held
  /// at its start value and the combination is reported.
  double rank_tolerance = 1e-6;
  /// Threads for the residual evaluations where every derivative is analytic (serial chains);
  /// the result is the same for any number up to the order of floating-point sums.
  int threads = 1;
  /// Told "calibrate" with the solver's iteration of max_iterations (optional).
  Progress progress;
  Solver solver = Solver::automatic;
};

/// SVD of the column-scaled identification Jacobian (each column divided by its norm, so the
/// figures do not depend on the units of the parameters).
struct Identifiability {
  int rows = 0;                  ///< residual components
  int parameters = 0;            ///< columns analysed
  int rank = 0;                  ///< singular values above rank_tolerance·σ_max
  double condition = 0;          ///< σ_max / σ_min over the identifiable part
  double o1 = 0;                 ///< (σ₁⋯σ_r)^(1/r) / √rows (Borm & Menq)
  double o3 = 0;                 ///< σ_min (of the identifiable part)
  double o4 = 0;                 ///< σ_min² / σ_max, noise amplification index (Nahvi & Hollerbach)
  Eigen::VectorXd singular_values;
  /// Unidentifiable combinations, one per null direction: "limb1.db_y +1 mm, limb2.db_y -0.98 mm"
  /// (the parameter change, in each parameter's unit, that changes no measurement).
  std::vector<std::string> combinations;
  /// The best determined direction's opposite: the combination along the smallest identifiable
  /// singular value (the one the noise moves most), in the same form.
  std::string weakest;
  /// Parameters with a zero column: no measurement depends on them.
  std::vector<int> unobserved;
  /// The parameters to hold so that the rest is identifiable (one per null direction + unobserved).
  std::vector<int> dependent;
};

/// Analyses the identification Jacobian `j` whose columns are the parameters `columns` of `model`.
[[nodiscard]] Identifiability analyse(const Eigen::MatrixXd& j, std::span<const int> columns, const kin::Model& model,
                                      double rank_tolerance = 1e-6);

/// An instrument frame's estimated registration: P_workpiece = r·P_instrument + t.
struct FrameEstimate {
  std::string name;                        ///< the frame (file path, or the name in `# frame: instrument NAME`)
  std::uint8_t free = 0;                   ///< components requested (RegistrationBit)
  std::uint8_t held = 0;                   ///< requested but not identifiable: held at the start
  std::vector<std::string> held_why;       ///< per held component: "rz: explained by EC0C (+1 rad per rad)"
  Eigen::Vector3d t = Eigen::Vector3d::Zero();     ///< mm
  Eigen::Matrix3d r = Eigen::Matrix3d::Identity();
  Eigen::Vector3d start_t = Eigen::Vector3d::Zero();   ///< the rigid-fit start
  Eigen::Matrix3d start_r = Eigen::Matrix3d::Identity();
  /// ±1σ of tx ty tz (mm) and of the rotation about x y z (rad); NaN where not estimated.
  std::array<double, 6> stddev{};
  std::size_t measurements = 0;            ///< fitted measurements in this frame
  /// The rotation as a vector (axis × angle, rad).
  [[nodiscard]] Eigen::Vector3d rotation() const;
};

/// The fit of one file: χ² of its residuals weighted by its own uncertainty.
struct FileFit {
  std::string file;
  int rows = 0;              ///< fitted residual components
  double sigma_mm = 0;       ///< σ used for its length rows (declared or kDefaultSigma)
  double sigma_rad = 0;      ///< σ_angle used for its angle rows
  bool declared = false;     ///< `# sigma:` or `# sigma_angle:` given
  bool lengths = false;      ///< the file has length rows (tool tip, struts)
  bool angles = false;       ///< the file has angle rows (tool axis)
  double chi2 = 0;           ///< Σ (residual / σ)² at the solution
  /// √(χ² / (rows·(1 − p/N))): about 1 when σ is right and the model fits; far above 1 flags a
  /// σ too small, an outlier or a model error, far below 1 a σ too large.
  double normalised_rms = 0;
};

struct IdentifyResult {
  std::vector<double> values;     ///< every parameter of the model (start values where not identified)
  std::vector<int> identified;    ///< indices estimated
  std::vector<int> held;          ///< indices held at the start because they were not identifiable
  std::vector<double> stddev;     ///< per parameter; NaN when not estimated (covariance σ̂²(JᵀJ)⁻¹)
  /// σ̂²(JᵀJ)⁻¹ of the identified parameters (rows and columns in `identified` order, in the
  /// parameters' units mm and rad); with instrument frames, their block of the joint covariance.
  Eigen::MatrixXd covariance;
  Identifiability start;          ///< at the start model, over the requested set
  Identifiability solution;       ///< at the result, over the identified set
  int iterations = 0;             ///< LM iterations (steps tried, as Ceres counts them)
  Solver solver = Solver::ceres;  ///< the solver that ran (never automatic)
  double seconds = 0;             ///< wall time of identify()
  double initial_cost = 0;        ///< ½‖res‖² of the fitted measurements at the start (mm²)
  double final_cost = 0;          ///< the same at the result
  double sigma = 0;               ///< residual standard deviation √(2·cost / (rows − identified)), mm-eq
  double lambda = 0;              ///< the ridge λ used (0 for other methods)
  bool usable = false;            ///< ceres::Solver::Summary::IsSolutionUsable
  std::string message;            ///< ceres::Solver::Summary::message
  bool converged = false;         ///< Ceres stopped on a tolerance (not the iteration limit or a failure)
  std::vector<FrameEstimate> frames;  ///< instrument frames of the fitted data
  /// Machine parameters held because an instrument frame's placement explains them, with why.
  std::vector<std::string> held_why;
  std::vector<FileFit> files;         ///< per file of the fitted data, in order of appearance
  double sigma_reference_mm = kDefaultSigma;  ///< σ₀: the residuals and costs are in mm at this accuracy
};

/// The measurements with every instrument-frame value mapped into the workpiece frame by the
/// estimated registration (Source::frame cleared), for reports and validation. Throws
/// postproc::Error (usage) for a frame the result does not know (held-out rows of a set-up no
/// fitted row determines).
[[nodiscard]] std::vector<Measurement> registered(std::span<const Measurement> data, const IdentifyResult& result);

/// Identifies the parameters from the measurements not marked `validate`, starting from
/// start_model's values. Throws postproc::Error (usage) for no measurements, a bad index, a
/// measurement the start model cannot evaluate (named by its label), or more parameters than
/// residual components.
[[nodiscard]] IdentifyResult identify(const kin::Model& start_model, std::span<const Measurement> data,
                                      const IdentifyOptions& options = {});

/// A rotary joint whose values fit far better with the opposite sign (a sign convention that
/// differs between the instrument's records and the machine file: ISO 841 table axes turn the
/// other way than the head's).
struct SignHint {
  std::string joint;
  double cost_ratio = 0;   ///< final cost as given / final cost with the sign reversed
  double sigma_mm = 0;     ///< residual σ with the sign reversed
};
/// When `result` is suspicious (σ above 3σ₀, not converged, or an angular error parameter beyond
/// 0.05 rad), identifies again with each rotary joint's values
/// negated and returns those that fit at least 10 times better (cost). Empty otherwise.
[[nodiscard]] std::vector<SignHint> opposite_sign_hints(const kin::Model& start_model, std::span<const Measurement> data,
                                                        const IdentifyOptions& options, const IdentifyResult& result);

/// The residual of one measurement against a model (residual_rows() entries, mm-equivalent, as
/// the file comment says); false when the model cannot evaluate it (forward/inverse fails).
bool measurement_residual(const kin::Model& model, const Measurement& m, double* out,
                          double orientation_weight = kOrientationWeight);

/// Stacked residuals of every measurement (NaN rows where the model cannot evaluate one).
[[nodiscard]] Eigen::VectorXd residuals(const kin::Model& model, std::span<const Measurement> data,
                                        double orientation_weight = kOrientationWeight);

/// Stacked residuals and their derivatives by the parameters `columns` (analytic where the
/// model has them, else central differences). Throws postproc::Error (usage) naming a measurement
/// the model cannot evaluate.
void linearise(const kin::Model& model, std::span<const Measurement> data, std::span<const int> columns,
               Eigen::VectorXd& res, Eigen::MatrixXd& jac, double orientation_weight = kOrientationWeight,
               bool numeric = false);

/// Per measurement: tool-tip (or strut) error |residual position rows| in mm and tool-axis error
/// in degrees (NaN where the kind has none). For reports.
struct MeasurementError {
  double position_mm = 0;
  double angle_deg = 0;
};
[[nodiscard]] MeasurementError measurement_error(const kin::Model& model, const Measurement& m);

/// Document 001's simulation experiment (section 3), for the tests and the bench.
namespace doc001 {

/// Target in the workpiece frame: tool tip at base height z (mm), tilt θ toward direction φ
/// (rad), no torsion, X = Y = 0 offset (x, y mm). The workpiece frame is the base frame turned by
/// π about X (see prs_hybrid.hpp).
[[nodiscard]] kin::Pose target(double z, double theta, double phi, double x = 0, double y = 0);

/// The 27 measuring poses (z, φ, θ): on each plane z = 700, 800, 900 mm, θ = 0 and θ = 40° at
/// φ = 0°, 45°, …, 315°. The paper shows its pose pattern only in a figure (fig. 5); this is our
/// reading.
[[nodiscard]] std::vector<kin::Pose> pose_set();

/// Simulated measurements: joints from `controller`'s nominal closed-form inverse (what the
/// controller commands), pose from `truth`'s forward kinematics plus uniform noise: ±noise_mm per
/// position component and a small rotation with components uniform in ±noise_deg (workpiece
/// frame). has_torsion as given (5-DoF data keep the noisy rotation; identify ignores its torsion).
[[nodiscard]] std::vector<Measurement> simulate(const kin::PrsHybrid& controller, const kin::PrsHybrid& truth,
                                                std::span<const kin::Pose> targets, unsigned seed, bool has_torsion,
                                                double noise_mm = 0.01, double noise_deg = 0.01);

/// Largest tool-tip error (mm) on the z = 700 mm plane over θ = 0…40° (1° steps) and φ in 5°
/// steps: joints from `commanding.inverse` (its own errors; the closed form for a nominal model),
/// tip from `truth.forward`. Infinity if a pose cannot be commanded or reached.
[[nodiscard]] double max_tip_error_z700(const kin::PrsHybrid& commanding, const kin::PrsHybrid& truth);

}  // namespace doc001

}  // namespace postproc::cal
