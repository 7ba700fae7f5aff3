#pragma once
/// @file
/// Cubic B-spline curves (non-rational NURBS with unit weights) for the contour-error estimate of
/// document 004: least-squares fitting of a tool-path polyline, windowed fitting of long programs,
/// and the foot point of a query point on the fitted curve.
///
/// Document 004 fits a NURBS curve through the theoretical tool points of the NC program and takes
/// the contour error of an actual point q as its distance to that curve, found by "tangential-error
/// back-estimation": the error vector q − C(u) is split into a component along the tangent C'(u)
/// and a normal one, and the parameter is moved back by the tangential part until only the normal
/// (contour) error is left. project() implements that iteration with a Newton fallback.
///
/// Units: points, residuals and distances are in mm, in whatever frame the caller's points are in
/// (the workpiece frame for contour errors). Parameters u are dimensionless; fitted curves have the
/// domain [0, 1]. Algorithm numbers refer to Piegl & Tiller, "The NURBS Book", 2nd ed.

#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

#include <Eigen/Core>

namespace postproc::contour {

/// A clamped cubic B-spline curve in R³. Immutable and thread-safe.
class CubicCurve {
 public:
  static constexpr int degree = 3;

  /// Point and derivatives at one parameter.
  struct Derivatives {
    Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< C(u), mm
    Eigen::Vector3d first = Eigen::Vector3d::Zero();   ///< C'(u), mm per unit of u
    Eigen::Vector3d second = Eigen::Vector3d::Zero();  ///< C''(u), mm per unit of u²
  };
  /// The parameter interval [begin, end].
  struct Domain {
    double begin = 0.0;
    double end = 1.0;
  };

  /// The constant curve at the origin (4 control points at 0, domain [0, 1]).
  CubicCurve();
  /// `knots`: non-decreasing, clamped (the first 4 and the last 4 equal), of size
  /// control_points.size() + 4, with a non-empty domain; `control_points`: ≥ 4, mm.
  /// Throws postproc::Error (usage) naming the violated condition.
  CubicCurve(std::vector<double> knots, std::vector<Eigen::Vector3d> control_points);

  /// C, C' and C'' at u (A2.3 basis-function derivatives). u outside the domain is clamped to it.
  [[nodiscard]] Derivatives evaluate(double u) const;
  /// C(u), mm (A2.2 basis functions; u clamped to the domain).
  [[nodiscard]] Eigen::Vector3d point(double u) const;
  [[nodiscard]] Domain domain() const;
  /// Number of control points.
  [[nodiscard]] std::size_t size() const { return control_points_.size(); }
  [[nodiscard]] const std::vector<double>& knots() const { return knots_; }
  [[nodiscard]] const std::vector<Eigen::Vector3d>& control_points() const { return control_points_; }

 private:
  [[nodiscard]] std::size_t span(double u) const;
  std::vector<double> knots_;
  std::vector<Eigen::Vector3d> control_points_;
};

/// Options of fit_cubic(). Every member has a usable default.
struct FitOptions {
  /// Target of the largest residual |C(u_i) − P_i|, mm (0.1 µm by default). Must be > 0.
  double tolerance_mm = 1e-4;
  /// Upper limit on the control points (0: the number of distinct points, i.e. interpolation).
  std::size_t max_control_points = 0;
  /// Consecutive points closer than this, mm, count as one (they get the same parameter).
  double duplicate_mm = 1e-9;
};

/// The outcome of fit_cubic(): never silent, check within_tolerance.
struct FitResult {
  CubicCurve curve;
  /// The parameter assigned to each input point (centripetal; non-decreasing, 0 … 1).
  std::vector<double> params;
  /// max_i |C(u_i) − P_i| and its root mean square, mm. These are distances at the assigned
  /// parameters, so upper bounds of the distances of the points to the curve.
  double max_residual_mm = 0.0;
  double rms_residual_mm = 0.0;
  /// Control points of the final curve (curve.size()).
  std::size_t control_points = 0;
  /// Number of least-squares solves made while increasing the control points.
  int rounds = 0;
  /// Whether max_residual_mm ≤ tolerance_mm (interpolation reaches it up to rounding).
  bool within_tolerance = false;
};

/// Fits a clamped cubic B-spline to a polyline (mm), interpolating the end points.
///
/// Choices (Piegl & Tiller ch. 9):
/// - Parameters: centripetal, Δu_i ∝ √|P_i − P_{i−1}|, normalised to [0, 1]. Runs of duplicate
///   points (closer than duplicate_mm) are fitted once and share one parameter.
/// - Knots: the averaging technique of eq. 9.69 for least squares, eq. 9.8 when the number of
///   control points equals the number of distinct points (interpolation).
/// - Solve: least squares with the end points fixed (eq. 9.63–9.67); the normal matrix is banded
///   (half-bandwidth 3) and is solved by a banded Cholesky factorisation, so memory and time are
///   O(points + control points) per round.
/// - Control points: start with min(N, 4 + N/8) (N distinct points) and grow by
///   (max residual / tolerance)^(1/4) · 1.1 (the h⁴ error law of cubics), at least ×1.25 and at
///   most ×4, until the tolerance is met or N (interpolation) or max_control_points is reached.
/// - Few points: 1 distinct point gives a constant curve; 2 the straight segment, exactly
///   (u proportional to arc length there); 3 the interpolating parabola (centripetal parameter of
///   the middle point), degree-elevated to a cubic Bézier curve.
/// Throws postproc::Error (usage) for no points, a non-finite coordinate (naming its index) or a
/// tolerance ≤ 0.
[[nodiscard]] FitResult fit_cubic(std::span<const Eigen::Vector3d> points, const FitOptions& options = {});

/// One piece of a windowed fit: the fit of points [begin, end) of the whole polyline.
struct FitPiece {
  std::size_t begin = 0;
  std::size_t end = 0;
  FitResult fit;
  /// The parameter of point i (begin ≤ i < end) on this piece's curve.
  [[nodiscard]] double param(std::size_t i) const { return fit.params[i - begin]; }
};

/// A long polyline as overlapping fitted pieces.
struct WindowedFit {
  std::vector<FitPiece> pieces;
  /// Number of points of the polyline.
  std::size_t points = 0;
  /// The piece in which point i is most central (the largest min(i − begin, end − 1 − i)); the
  /// earlier piece on a tie. Throws postproc::Error (usage) when i ≥ points.
  [[nodiscard]] const FitPiece& piece_for(std::size_t i) const;
  /// Whether every piece met its tolerance.
  [[nodiscard]] bool within_tolerance() const;
  /// The largest max_residual_mm of the pieces, mm.
  [[nodiscard]] double max_residual_mm() const;
};

/// Fits a long polyline piece by piece so that working memory is bounded by the window, not the
/// program: piece k fits points [k·(window − overlap), … + window); consecutive pieces share
/// `overlap` points, and the last piece is shifted back to end at the last point, so every piece
/// has min(window, points) points. With overlap ≥ 8 or so, the point used for a query
/// (piece_for) is ≥ overlap/2 points away from its piece's free ends, where a least-squares piece
/// is least constrained. Requires window ≥ 4 and overlap < window; throws postproc::Error (usage)
/// otherwise. `visit` gets each piece as it is fitted (in order) and may keep or drop it.
void for_each_window(std::span<const Eigen::Vector3d> points, std::size_t window, std::size_t overlap,
                     const FitOptions& options, const std::function<void(FitPiece&&)>& visit);
/// for_each_window() keeping every piece.
[[nodiscard]] WindowedFit fit_windows(std::span<const Eigen::Vector3d> points, std::size_t window,
                                      std::size_t overlap, const FitOptions& options = {});

/// Options of project().
struct ProjectOptions {
  /// Stop when a step moves the curve point by less than this, |Δu|·|C'(u)|, mm.
  double step_tolerance_mm = 1e-11;
  /// Steps of tangential back-estimation before switching to Newton.
  int max_back_estimation = 30;
  /// Newton steps after that.
  int max_newton = 60;
  /// Also compare with the two end points of the curve and keep the closer.
  bool check_ends = false;
  /// When > 0, also sample this many points per knot span; if one is closer than the local
  /// result, restart from it (guards against a far local minimum; O(control points) per query).
  int samples_per_span = 0;
};

/// How project() found its answer.
enum class ProjectMethod : std::uint8_t {
  back_estimation,  ///< the tangential back-estimation converged
  newton,           ///< back-estimation failed (diverged or too slow); Newton finished
  global,           ///< an end point or a coarse sample of ProjectOptions beat the local answer
};

/// The foot point of q on a curve.
struct ProjectResult {
  double u = 0.0;                                    ///< parameter of the foot point
  Eigen::Vector3d point = Eigen::Vector3d::Zero();   ///< C(u), mm
  double distance = 0.0;                             ///< |q − C(u)|, mm (the contour error)
  int iterations = 0;                                ///< back-estimation plus Newton steps
  ProjectMethod method = ProjectMethod::back_estimation;
  bool converged = false;                            ///< false: the step limit was reached
};

/// The (local) closest point of `curve` to q (mm), starting from u0 (clamped to the domain).
///
/// Document 004's tangential-error back-estimation: u ← u + ((q − C(u))·C'(u)) / |C'(u)|², which
/// removes the tangential component of the error to first order, clamped to the domain, until the
/// step is below step_tolerance_mm. It converges linearly with ratio ≈ d·κ (normal distance times
/// curvature), so in a few steps for small contour errors. If a step increases the distance or
/// max_back_estimation steps are not enough, Newton's method on f(u) = (C(u) − q)·C'(u),
/// f'(u) = |C'|² + (C − q)·C'', takes over, with a halving line search on the distance (and the
/// back-estimation step where f' ≤ 0). The answer is a local minimum near u0 unless check_ends /
/// samples_per_span ask for the global guards.
[[nodiscard]] ProjectResult project(const CubicCurve& curve, const Eigen::Vector3d& q, double u0,
                                    const ProjectOptions& options = {});

}  // namespace postproc::contour
