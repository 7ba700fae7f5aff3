#pragma once
// Instrument frames while identify() estimates them (identify.hpp): the registration of a
// measured pose, the rigid-fit start, and which components the data separate from the machine.
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "postproc/calibration/measurement.hpp"
#include "postproc/kinematics/model.hpp"

namespace postproc::cal {

using Mat3 = Eigen::Matrix3d;
using Vec3 = Eigen::Vector3d;

/// An instrument frame while it is estimated; `reg` is its Ceres parameter block (t mm, ω rad).
struct FrameState {
  std::string name;
  std::uint8_t free = 0;
  std::uint8_t held = 0;
  Mat3 r0 = Mat3::Identity();
  std::array<double, 6> reg{};
  std::size_t measurements = 0;
  /// The identified components (free and not held), as indices 0…5.
  [[nodiscard]] std::vector<int> estimated() const {
    std::vector<int> out;
    for (int k = 0; k < 6; ++k)
      if ((free & (1u << k)) != 0 && (held & (1u << k)) == 0) out.push_back(k);
    return out;
  }
};

/// exp(ω): the rotation by |ω| about ω.
[[nodiscard]] Mat3 rotation_of(const Vec3& w);

/// An instrument frame's registration: P_w = exp(ω)·r0·P_i + t, with reg = (t, ω).
[[nodiscard]] kin::Pose registered_pose(const kin::Pose& measured, const Mat3& r0, const double* reg);

/// Start values of each frame's registration: the rigid transform (no scale) that best carries
/// the measured points onto the start model's (Umeyama), or, for a frame with only tool axes,
/// the rotation that best carries the measured axes onto the model's (Kabsch). Only when every
/// component the data can move is free; otherwise the identity (the held components stay 0).
void start_registration(const kin::Model& model, std::span<const Measurement> fit, std::span<const int> frame_of,
                        std::vector<FrameState>& frames);

/// The instrument frames come first: a registration component is estimated unless no
/// measurement depends on it or the frames' components before it already explain it; a machine
/// parameter that the registration (and the machine parameters kept before it) explains within
/// `tolerance` (residual norm of its unit column) is held at its start value. The data cannot
/// tell such a parameter from where the instrument stood, so the machine file's value stays and
/// the unknown placement takes the difference (attributing it to the machine instead would move
/// the machine's model by the instrument's misregistration). Records why.
void separate_registration(const Eigen::MatrixXd& machine, const Eigen::MatrixXd& reg,
                           std::span<const std::pair<int, int>> reg_of, const kin::Model& model,
                           std::vector<int>& identified, std::vector<int>& held, std::vector<int>& dependent,
                           std::vector<std::string>& machine_why, std::vector<FrameState>& frames,
                           std::vector<std::vector<std::string>>& frame_why, double tolerance);

}  // namespace postproc::cal
