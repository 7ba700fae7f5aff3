#pragma once
/// @file
/// Inverse kinematics with the tool tip exact and the tool axis as near as a bounded rotary
/// correction allows: the remap of a pose near a singular configuration (the tool axis along a
/// rotary axis, B ≈ 0 on a B/C table), where matching the tool axis exactly needs rotary motions
/// that grow without bound (δC ≈ ε / sin B).
///
/// The problem, in joint values x (mm; rad for rotary joints) from the anchor a (the nominal
/// joints of the block):
///
///     minimise |e_O(x)|² + λ²·|x_r − a_r|²   subject to   P(x) = P_target,
///
/// e_O the tool-axis deviation (two components normal to the target axis), x_r the rotary joints.
/// Gauss–Newton with the tip as a hard constraint (KKT system per step, step halving on an exact
/// penalty merit). The damping is set once per pose from the tool-axis error e at the anchor,
/// λ = max(e / (2·c), √(e / K)), c the allowed rotary correction, K the allowed slope: in the
/// linearised problem each direction of the rotary joints gets σ/(σ² + λ²)·e ≤ e/(2λ) ≤ c (σ its
/// singular value), so the orientation part of the correction stays within c, varies continuously
/// with the pose, and its slope against σ stays within e/λ² ≤ K (no steps in the joint path that
/// linear interpolation between blocks cannot follow), while away from the singularity (σ ≫ λ)
/// the tool axis is matched to a fraction λ²/(σ² + λ²) of its error.
/// A machine with fewer joints than tip + axis (the X Z B C lathe) gets the tip exactly and the
/// axis in least squares; its rotary joints move as far as the tip needs.

#include "postproc/kinematics/model.hpp"

namespace postproc::kin {

struct BoundedIkOptions {
  /// c: the largest rotary correction the tool-axis part of the solve may ask for, rad.
  double max_rotary_correction_rad = kDeg;
  /// s in λ = s·|e_O(a)| / (2c), 0…1: callers blend in the damping as the exact solution's
  /// rotary correction approaches c, so the joints stay continuous across the switch (see
  /// machine/program_map.cpp).
  double damping_share = 1;
  /// K, rad of rotary correction per rad of pose: the damping is also at least √(|e_O(a)| / K),
  /// which bounds the slope of the correction against σ by K (the curvature by |e|/λ³): the joint
  /// path stays smooth enough for linear interpolation between nearby blocks.
  double max_correction_slope = 1;
  double tolerance_mm = 1e-9;      ///< on |ΔP| at the end
  double step_tolerance = 1e-12;   ///< converged when no joint moves more (mm / rad)
  int max_iterations = 30;
};

/// The joints q nearest `anchor` that put the tool tip at target.p, with the tool axis as near
/// target's axis as the damping allows (see above). The Solve's residual_rad is the tool-axis
/// angle left (rad); status singular when the tip itself cannot be reached from here (e.g. a
/// lathe's tip on the spindle axis with a centre-height error).
[[nodiscard]] Solve bounded_inverse(const Model& model, const Pose& target, const JointVector& anchor, JointVector& q,
                                    const BoundedIkOptions& opt = {});

}  // namespace postproc::kin
