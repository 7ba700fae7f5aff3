#pragma once
/// @file
/// Following-error and contour-error prediction (document 004).
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
/// The precompensation that uses these predictions is in precompensate.hpp.

#include <cstdint>
#include <vector>

#include "postproc/contour/path.hpp"
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

/// The prediction of one run of the path (the part of predict() for `run`): fills points[i] for
/// i in [run.begin, run.end) and raises max_following (per joint) and `unconverged`. `retime`: the
/// commands are not the path's own, so under the combined-axes feed metric the moves are re-timed
/// by their corrected lengths.
void predict_run(const Path& path, const kin::Model& actual, const Reference& ref,
                 const std::vector<kin::JointVector>& commands, const Run& run, bool retime,
                 std::vector<PointPrediction>& points, std::vector<double>& max_following, std::uint64_t& unconverged);

}  // namespace postproc::contour
