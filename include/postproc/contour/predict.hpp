#pragma once
/// @file
/// Following-error and contour-error prediction (document 004) and contour precompensation.
///
/// Prediction at every path point i (commands q_i at times t_i, path.hpp):
/// 1. axis velocities: between two points the commands move at w = Δq/Δt (the joint velocities
///    that the tool speed from the feed gives through the Jacobian, here taken from the joint
///    commands themselves);
/// 2. following error of each joint: the drive's exact response to that piecewise-constant
///    velocity from rest at the run's start (drive.hpp velocity_jump / propagate), which is
///    document 004's e = q̇/Kv in lag mode at constant speed and also holds through the
///    transients at starts, stops and changes of speed;
/// 3. actual joints q_i − e_i and the actual pose P′_i, O′_i through the calibrated model;
/// 4. contour errors of P′_i, O′_i against the intended contour (reference.hpp).
///
/// Precompensation: the predicted contour error (the normal error vector of the tip, and the
/// rotation of the tool axis, never the lag along the path) is mapped to joint corrections
/// through the pose Jacobian at the point, Δq = J⁺·[ε_p; L·ε_θ] (least squares over the tip and
/// the two tool-axis directions, minimum norm where the machine is redundant; L weighs radians
/// against millimetres), added to the commands, and the prediction is repeated on the corrected
/// commands against the same intended contour until the largest predicted contour error stops
/// improving by more than the tolerance.

#include <cstdint>
#include <vector>

#include "postproc/contour/path.hpp"
#include "postproc/progress.hpp"
#include "postproc/contour/reference.hpp"

namespace postproc::contour {

/// Predicted errors at one path point.
struct PointPrediction {
  kin::JointVector following;                       ///< following error per joint, mm / degrees
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();    ///< actual tool tip P′, mm
  Eigen::Vector3d axis = Eigen::Vector3d::UnitZ();  ///< actual tool axis O′ (unit)
  Eigen::Vector3d error = Eigen::Vector3d::Zero();  ///< tool-tip contour error vector (foot − P′), mm
  double tip_mm = 0;                                ///< |error|, mm
  double axis_rad = 0;                              ///< tool-axis contour error angle, rad
  Eigen::Vector3d rotation = Eigen::Vector3d::Zero();  ///< rotation O′ → O*, rad
};

struct Prediction {
  std::vector<PointPrediction> points;  ///< per path point
  Summary tip;                          ///< tool-tip contour error, mm (over every path point)
  Summary axis;                         ///< tool-axis contour error, rad
  std::vector<double> max_following;    ///< per joint, mm / degrees
  std::uint64_t unconverged = 0;        ///< foot points whose search did not converge
};

/// Predicts the errors of `commands` (one joint vector per path point; nullptr: the path's own
/// commands) on `actual` against `ref`.
[[nodiscard]] Prediction predict(const Path& path, const kin::Model& actual, const Reference& ref,
                                 const std::vector<kin::JointVector>* commands = nullptr);

struct PrecompensateOptions {
  int max_iterations = 12;
  /// Stop when the iteration's figure (largest tip error + L × largest axis error, mm) improved by
  /// less than this, mm …
  double tolerance_mm = 1e-6;
  /// … or by less than this fraction of itself.
  double relative_tolerance = 0.05;
  /// L of the orientation rows, mm per rad.
  double orientation_length_mm = 100;
  /// Relative singular-value cut of the pseudo-inverse.
  double rcond = 1e-6;
  /// Add the drives' lag of the correction itself to the commands (δ = d + e₁·ḋ), so that the
  /// actual joints move by d: fewer iterations.
  bool invert_lag = true;
  /// Told "contour: correcting" with the iteration number of max_iterations (optional).
  Progress progress;
};

struct Precompensation {
  std::vector<kin::JointVector> commands;  ///< corrected joint commands per path point
  Prediction before;
  Prediction after;
  int iterations = 0;
  bool converged = false;
  std::vector<double> history_mm;          ///< largest tip contour error after each iteration, mm
  std::vector<double> history_rad;         ///< … tool-axis, rad
};

/// Corrects every block end point of the path except the runs' last points (the machine stops and
/// settles on those commands, so they stay as programmed); run starts and arc chord points keep
/// their commands as well (they are not written words of the program).
[[nodiscard]] Precompensation precompensate(const Path& path, const kin::Model& actual, const Reference& ref,
                                            const PrecompensateOptions& opt = {});

}  // namespace postproc::contour
