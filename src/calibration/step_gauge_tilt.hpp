#pragma once
// The plate-tilt model of the step gauge, shared by the map builder and the simulator.
#include <Eigen/Core>

namespace postproc::cal {

/// The step gauge's axis letters, as its files name them.
inline constexpr char kAxis[3] = {'x', 'y', 'z'};

/// The plate's tilt (θx, θy, rad) moves a pyramid at d (mm) from the reference pyramid by ω×d
/// with ω = (θy, −θx, 0).
inline Eigen::Vector3d tilt_shift(const Eigen::Vector2d& theta, const Eigen::Vector3d& d) {
  return {-theta.x() * d.z(), -theta.y() * d.z(), theta.x() * d.x() + theta.y() * d.y()};
}

}  // namespace postproc::cal
