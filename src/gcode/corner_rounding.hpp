// Rounding arc between two path elements of a plane, each a straight move or an arc: the circle of
// the given radius tangent to both, on the side the path turns to, whose tangent points lie on the
// elements. Fanuc ",R" (B-63944EN-1 "Optional chamfering and corner R"), Sinumerik RND= (840D sl
// Fundamentals, "Chamfer, rounding") and Heidenhain RND R (TNC 640 User's Manual, "Rounding
// corners RND") all build this arc; each caller shortens its moves to the tangent points.
#pragma once

#include <optional>
#include <string>

#include <Eigen/Core>

#include "postproc/gcode/motion.hpp"

namespace postproc::gcode {

/// The rounding arc in plane coordinates (u, v of the plane): its centre, the tangent point on the
/// first element (`from`, where the first move now ends) and on the second (`to`, where the second
/// now starts), and its direction.
struct RoundingArc {
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  Eigen::Vector2d from = Eigen::Vector2d::Zero();
  Eigen::Vector2d to = Eigen::Vector2d::Zero();
  bool ccw = false;
};

/// The arc of radius `r` (mm) rounding the corner where move `m` ends and move `n` begins (both in
/// plane `p`). Without one, `why` says why; `stops` is true where the controller itself stops
/// (the arc does not fit on the moves), false where this version does not build it (a full circle
/// or multi-turn arc, a move without length, no corner).
[[nodiscard]] std::optional<RoundingArc> rounding_arc(const Motion& m, const Motion& n, PlaneAxes p, double r,
                                                      std::string& why, bool& stops);

/// Shortens `first` to end at `ra.from` (an arc keeps its centre) and returns the rounding arc as a
/// move with `first`'s modes and feed and no words of its own, from `ra.from` to `ra.to`, radius `r`.
[[nodiscard]] Motion round_corner(Motion& first, PlaneAxes p, const RoundingArc& ra, double r);

/// Makes `next` start at `at` in the plane (an arc keeps its centre and ends where it did).
void start_at(Motion& next, PlaneAxes p, const Eigen::Vector2d& at);

/// Signed sweep from `a` to `b` about `c` in the arc's direction, in (−2π, 2π).
[[nodiscard]] double sweep_between(const Eigen::Vector2d& c, const Eigen::Vector2d& a, const Eigen::Vector2d& b,
                                   bool ccw);

}  // namespace postproc::gcode
