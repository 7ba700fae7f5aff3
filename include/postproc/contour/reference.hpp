#pragma once
/// @file
/// The intended contour of a commanded path (document 004): cubic B-spline fits through the
/// intended tool points P_i = FK(q_i) and through the tool-axis marker points Q_i = P_i + L·O_i
/// (L = marker_length_mm), run by run, in windows so that the fitting work stays bounded, and cut
/// into spans at corners (a turn of more than 15° of the tip or marker path between two moves: a
/// cubic through a corner would overshoot; the controller moves straight there); and the contour
/// error of an actual pose against them:
/// - tool tip: the foot point C(u*) of the actual tip P' on the tool-point curve (tangential-error
///   back-estimation with a Newton fallback, nurbs.hpp); the error vector is C(u*) − P' (mm), normal
///   to the curve, so the harmless lag along the path is not part of it;
/// - tool axis: the intended axis at the foot, O*(u*) = (Q(v) − C(u*)) / |Q(v) − C(u*)|, where v is
///   the marker curve's parameter at the same place (mapped through the point parameters of both
///   fits: the same fraction between the same two points); the error is the angle between the
///   actual axis O' and O*(u*) (rad), and the rotation vector O' × O* scaled to that angle.
///
/// Intended poses come from the model given (for contour work the calibrated machine: the path
/// the machine would follow without servo lag).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "postproc/contour/nurbs.hpp"
#include "postproc/contour/path.hpp"
#include "postproc/kinematics/model.hpp"

namespace postproc::contour {

struct ReferenceOptions {
  FitOptions fit;                  ///< tolerance 0.1 µm by default
  std::size_t window = 2000;       ///< points per fitted piece
  std::size_t overlap = 64;        ///< points shared by consecutive pieces
  double marker_length_mm = 100;   ///< L: distance of the tool-axis marker point from the tip
  /// Intended poses through the controller's nominal model instead of the calibrated one (the
  /// path the drawing means: for judging geometric and servo errors together, --mode all).
  bool nominal = false;
};

/// The contour error of one actual pose.
struct ContourError {
  Eigen::Vector3d foot = Eigen::Vector3d::Zero();    ///< C(u*), mm
  Eigen::Vector3d vector = Eigen::Vector3d::Zero();  ///< C(u*) − P', mm (what the tip must move by)
  double distance = 0;                               ///< |vector|, mm
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();   ///< intended tool axis O*(u*) (unit)
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero();///< rotation taking O' to O*, rad (axis × angle)
  double angle = 0;                                  ///< |rotation|, rad
  std::size_t point = 0;                             ///< index (Path::points) of the reference point nearest the foot
  double u = 0;                                      ///< foot parameter on its piece
  bool converged = true;
};

/// A place on a reference run, for tracking along the path (Reference::place_on, follow,
/// error_within): the chord from path point `point` to the next one at `fraction` (0 … 1; the
/// run's last point with fraction 0), and its arc measure (Reference::arc), mm.
struct Place {
  std::size_t point = 0;
  double fraction = 0;
  double arc = 0;
  double distance = 0;  ///< of the pose placed to its chord point: tool tip, or marker point if larger, mm
};

class Reference {
 public:
  /// Fits every run of `path` (intended poses through `model`, usually the calibrated machine).
  /// Runs of a single pose (one point, or points whose tips and markers all coincide within
  /// fit.duplicate_mm) have no curve: errors there are plain distances to that point and the angle
  /// to its axis. Throws postproc::Error: refused when the model's forward kinematics fails at a
  /// point (naming it and its line), usage for marker_length_mm ≤ 0 or a bad window / overlap.
  Reference(const Path& path, const kin::Model& model, const ReferenceOptions& opt = {});

  /// Intended pose of path point i.
  [[nodiscard]] const kin::Pose& intended(std::size_t i) const { return poses_[i]; }
  /// The contour error of actual pose `actual`, searching from path point `hint` (the point the
  /// actual pose is supposed to be near: its commanded point) within the run containing it. The
  /// foot is searched locally (a local minimum near the hint) on the piece where the hint is most
  /// central, then on the piece of the point nearest the foot if that is another one. Where the
  /// foot falls among coincident tool points (an orientation-only move), the actual marker point
  /// P′ + L·O′ is projected on the marker curve instead of mapping the tip parameter. No
  /// allocation; thread-safe. Throws postproc::Error (usage) when `hint` is not on a run.
  [[nodiscard]] ContourError error(const kin::Pose& actual, std::size_t hint) const;
  /// error() with the local search started `fraction` (0 … 1) of the way from the hint's curve
  /// parameter to that of path point `toward` (a neighbour of the hint): where the actual pose is
  /// known to lie between the two (its chord foot), the search starts next to the answer.
  [[nodiscard]] ContourError error(const kin::Pose& actual, std::size_t hint, std::size_t toward,
                                   double fraction) const;
  /// The contour error with the foot searched along the path, not by the nearest point in space:
  /// only the stretch of `around`'s run whose arc measure lies in [lo, hi] (extended to the points
  /// just outside) is searched — its chords for the nearest (tool tip; on orientation-only chords
  /// the marker point decides), then the fitted curve from there (error()); if the curve's local
  /// foot leaves the stretch or is a farther local minimum, the chord's foot stands. O(points in
  /// the stretch); no allocation. Throws postproc::Error (usage) when `around.point` is not on a run.
  [[nodiscard]] ContourError error_within(const kin::Pose& actual, const Place& around, double lo, double hi) const;
  /// The place of `pose` on the chord from path point k to k + 1 (k the run's last point: that
  /// point), by projecting the tool tip (the marker point on an orientation-only chord).
  [[nodiscard]] Place place_on(const kin::Pose& pose, std::size_t k) const;
  /// The place of `pose` tracked forward from `from` (never before it): the nearest chord among
  /// those starting at from.point whose arc measure begins before from.arc + reach, mm.
  [[nodiscard]] Place follow(const kin::Pose& pose, const Place& from, double reach) const;
  /// Arc measure of path point i along its run: the sum over the run's moves up to i of the larger
  /// of the tool tip's and the tool-axis marker point's displacement, mm (grows on orientation-only
  /// moves too; 0 at a run's first point).
  [[nodiscard]] double arc(std::size_t i) const { return arc_[i]; }
  /// The larger of the tool-tip and marker-point distances between two poses (the measure of arc()), mm.
  [[nodiscard]] double pose_distance(const kin::Pose& a, const kin::Pose& b) const;
  /// Largest fit residual over all pieces of both curves, mm.
  [[nodiscard]] double max_fit_residual_mm() const { return max_residual_; }
  [[nodiscard]] bool within_tolerance() const { return within_; }
  [[nodiscard]] const ReferenceOptions& options() const { return opt_; }
  /// Number of runs (those of the path given, one to one, single-point runs included).
  [[nodiscard]] std::size_t runs() const { return path_runs_.size(); }
  /// Run r's points [begin, end) in the path given. Throws postproc::Error (usage) when r ≥ runs().
  [[nodiscard]] Run run(std::size_t r) const;

 private:
  struct RunFit {
    std::size_t begin = 0, end = 0;   ///< path points
    bool curve = false;               ///< false: fewer than 2 distinct poses, no fit (plain distances)
    WindowedFit tip, marker;          ///< same windows: tip.pieces[j] and marker.pieces[j] hold the same points
  };
  [[nodiscard]] const RunFit* run_of(std::size_t i) const;
  [[nodiscard]] ContourError error_in(const RunFit& span, const kin::Pose& actual, std::size_t hint,
                                      std::size_t toward, double fraction) const;
  /// Whether the path turns by more than kCornerDeg at point k (tip or marker path), from the move
  /// that ends at k to the next move of the run (before `end`) that leaves k: repeated points
  /// (a zero-length block) do not hide a corner.
  [[nodiscard]] static bool corner(const std::vector<kin::Pose>& poses, std::size_t k, std::size_t end, double l,
                                   double dup);
  void fit_span(std::size_t begin, std::size_t end, double l, double dup, std::vector<Eigen::Vector3d>& tips,
                std::vector<Eigen::Vector3d>& markers);
  std::vector<Run> path_runs_;
  ReferenceOptions opt_;
  std::vector<kin::Pose> poses_;
  std::vector<RunFit> runs_;
  std::vector<std::uint32_t> run_index_;  ///< per path point: its run (index into runs_)
  std::vector<double> arc_;               ///< per path point: arc measure along its path run, mm
  std::vector<Eigen::Vector3d> markers_;  ///< per path point: the intended marker point P + L·O, mm
  /// Squared distances of tool tip p and marker point m to the chord k → k + 1 (k + 1 < its run's
  /// end) at their projection (the tip's; the marker point's on an orientation-only chord); sets
  /// the fraction.
  void chord_distance(const Eigen::Vector3d& p, const Eigen::Vector3d& m, std::size_t k, double& fraction, double& tip2,
                      double& marker2) const;
  /// The path run containing point i. Throws postproc::Error (usage) when i is on none.
  [[nodiscard]] const Run& path_run_of(std::size_t i) const;
  double max_residual_ = 0;
  bool within_ = true;
};

/// max, RMS and 95th percentile of a set of non-negative figures, with where the max is.
struct Summary {
  double max = 0;
  double rms = 0;
  double p95 = 0;
  std::size_t count = 0;
  std::size_t worst = 0;  ///< index (into whatever the figures were taken over) of the max
};
[[nodiscard]] Summary summarise(const std::vector<double>& values);

}  // namespace postproc::contour
