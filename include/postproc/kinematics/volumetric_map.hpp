#pragma once
/// @file
/// The volumetric positioning-error map of document 002 and the model decorator that applies it.
///
/// Document 002 measures, with 3-D step gauges, the positioning error E = (Ex, Ey, Ez) of the
/// machine at a grid of points of its work space, relative to a reference point (E = 0 there).
/// VolumetricMap interpolates those node values; VolumetricModel adds the interpolated error to
/// any model's forward kinematics.
///
/// Frames and units: grid coordinates and errors are in the machine frame (the frame of the
/// linear axes, Model::linear_position), mm. The decorator rotates E into the workpiece frame with
/// Model::machine_to_workpiece before adding it to the tool tip.

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "postproc/kinematics/model.hpp"

namespace postproc::kin {

/// An immutable regular grid of error vectors with interpolation. Thread-safe.
class VolumetricMap {
 public:
  enum class Interpolation : std::uint8_t {
    /// Piecewise trilinear: exact for node values and for any affine field; C⁰ across cells.
    trilinear,
    /// Tensor-product cubic Catmull–Rom: passes through the node values and is C¹ (value and
    /// gradient continuous across cell faces). Along each axis the row is extended past its ends
    /// by linear extrapolation of the last two nodes, so affine fields are still exact and an
    /// axis with 2 nodes is interpolated linearly.
    smooth,
  };
  /// What a point outside the grid box gets.
  enum class Outside : std::uint8_t {
    refuse,  ///< no value (std::nullopt; the decorator reports Status::outside_map)
    clamp,   ///< the value at the nearest point of the grid box (gradient 0 along clamped axes)
    zero,    ///< E = 0, no correction (gradient 0)
  };

  /// E and dE/dP at a point.
  struct Sample {
    Eigen::Vector3d error = Eigen::Vector3d::Zero();        ///< E, mm, machine frame
    Eigen::Matrix3d gradient = Eigen::Matrix3d::Zero();     ///< dE/dP: (i, j) = ∂E_i/∂P_j, mm/mm
  };

  /// `origin`: the node (0, 0, 0), machine frame, mm; `spacing`: node pitch per axis, mm, > 0;
  /// `counts`: nodes per axis, ≥ 2; `values`: counts.prod() error vectors (mm, machine frame),
  /// x fastest, then y, then z (index = i + nx·(j + ny·k)). Throws postproc::Error (usage)
  /// naming the problem when any of these is violated or a value is not finite.
  VolumetricMap(const Eigen::Vector3d& origin, const Eigen::Vector3d& spacing, const Eigen::Vector3i& counts,
                std::vector<Eigen::Vector3d> values, Interpolation interpolation = Interpolation::trilinear,
                Outside outside = Outside::refuse);

  /// E and dE/dP at p (machine frame, mm); std::nullopt when p is outside the grid box and the
  /// policy is refuse. Points within 1e-9 mm of the box count as inside.
  [[nodiscard]] std::optional<Sample> sample(const Eigen::Vector3d& p) const;
  /// E at p, mm (see sample()).
  [[nodiscard]] std::optional<Eigen::Vector3d> error(const Eigen::Vector3d& p) const;
  /// dE/dP at p, mm/mm (see sample()).
  [[nodiscard]] std::optional<Eigen::Matrix3d> gradient(const Eigen::Vector3d& p) const;
  /// Whether p lies in the grid box (with the 1e-9 mm slack).
  [[nodiscard]] bool contains(const Eigen::Vector3d& p) const;

  [[nodiscard]] const Eigen::Vector3d& origin() const { return origin_; }
  [[nodiscard]] const Eigen::Vector3d& spacing() const { return spacing_; }
  [[nodiscard]] const Eigen::Vector3i& counts() const { return counts_; }
  /// The far corner of the grid box, mm.
  [[nodiscard]] Eigen::Vector3d upper() const;
  [[nodiscard]] const std::vector<Eigen::Vector3d>& values() const { return values_; }
  /// The node value at grid index (i, j, k).
  [[nodiscard]] const Eigen::Vector3d& node(int i, int j, int k) const;
  [[nodiscard]] Interpolation interpolation() const { return interpolation_; }
  [[nodiscard]] Outside outside() const { return outside_; }

 private:
  Eigen::Vector3d origin_;
  Eigen::Vector3d spacing_;
  Eigen::Vector3i counts_;
  std::vector<Eigen::Vector3d> values_;
  Interpolation interpolation_;
  Outside outside_;
};

/// A model whose tool tip carries a volumetric positioning error: the decorator of any model.
/// Joints and parameters are the base model's.
///
/// forward: the base pose, then P += machine_to_workpiece(q) · E(linear_position(q)); the status
/// is outside_map when the map refuses the point (out then holds the uncorrected base pose).
/// jacobian: the base Jacobian plus d/dq [machine_to_workpiece(q) · E(linear_position(q))]; the
/// map's gradient is analytic, the derivatives of the two base virtuals are central differences
/// (1e-4 mm / degree) because the Model interface has no derivative of them — for the default
/// linear_position that is exactly the unit columns of the joints X, Y, Z.
/// inverse: a fixed-point iteration on the base's inverse — solve the base for the target point
/// shifted by −R·E(q) of the current solution, re-evaluate E, repeat (the map's gradient is ~1e-5,
/// so each pass gains ~5 digits); the base inverse keeps `start`'s branch every pass.
class VolumetricModel final : public Model {
 public:
  /// Throws postproc::Error (usage) when base or map is null.
  VolumetricModel(ModelPtr base, std::shared_ptr<const VolumetricMap> map);

  [[nodiscard]] std::string kind() const override { return "volumetric(" + base_->kind() + ")"; }
  [[nodiscard]] Solve forward(const JointVector& q, Pose& out) const override;
  [[nodiscard]] Jacobian jacobian(const JointVector& q) const override;
  [[nodiscard]] Solve inverse(const Pose& target, const JointVector& start, JointVector& q,
                              const IkOptions& opt = {}) const override;
  /// The decorator of base->with_values(values) with the same map.
  [[nodiscard]] std::shared_ptr<const Model> with_values(std::vector<double> values) const override;
  [[nodiscard]] Eigen::Matrix3d machine_to_workpiece(const JointVector& q) const override;
  [[nodiscard]] Eigen::Vector3d linear_position(const JointVector& q) const override;

  [[nodiscard]] const ModelPtr& base() const { return base_; }
  [[nodiscard]] const VolumetricMap& map() const { return *map_; }

 private:
  /// R(q)·E(linear_position(q)) in the workpiece frame, mm; nullopt when the map refuses.
  [[nodiscard]] std::optional<Eigen::Vector3d> correction(const JointVector& q) const;
  ModelPtr base_;
  std::shared_ptr<const VolumetricMap> map_;
};

}  // namespace postproc::kin
