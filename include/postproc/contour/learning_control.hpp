#pragma once
/// @file
/// Iterative learning control of the block end points on the time-domain simulation
/// (docs/contour.md "Refinement on the simulation").
///
/// The quasi-static prediction (predict.hpp) sees the errors at the block end points only. Where
/// the servo error lies inside the blocks (just after a corner, inside a long 5-axis block whose
/// joints the controller interpolates along a curve), correcting those points against it can cut
/// the part worse than before (the verification then withholds the correction). The learning step
/// instead takes every sample of the simulation of the commands as written: at a sample on the
/// segment from point a to point b at fraction f, a shift x_a, x_b of the two end points moves the
/// actual joints by about (1 − f)·x_a + f·x_b once the drives' lag of the shift is added to the
/// commands (δ = x + e₁·ẋ). The shifts of a run's correctable points minimise
///   Σ_samples |ε_s − A_s·((1 − f)·x_a + f·x_b)|²,
/// A_s = [J_tip; L·(I − O Oᵀ)·J_rot] at the sample's actual joints, ε_s = [tool-tip contour error;
/// L × tool-axis rotation]: block-tridiagonal normal equations (blocks of the joint count), damped
/// (Levenberg–Marquardt) and solved by block elimination along the run in O(points); then smoothed
/// along the run like the iteration's shifts (correction_smoothing).
///
/// With `dynamic` (the default of compensate since 2026-12-07) the samples are modelled through
/// the drives instead: the commands between point times are linear, so a shift x_k of point k
/// adds x_k·φ_k(t) to the command (φ_k the hat function of the point times t_{k−1}, t_k, t_{k+1})
/// and, every drive being linear, x_k·ψ_k(t) to the actual joints, ψ_k = the drive's response to
/// φ_k (a sum of three ramp responses, closed form: drive.hpp propagate). Every sample couples the
/// points whose response has not died out (8 time constants of the slowest drive): banded
/// normal equations, solved by sparse LDLᵀ. A run whose points are dense (more than
/// kDynamicPointsPerHorizon on average within that time, e.g. CAM finishing output of short
/// blocks) keeps the quasi-static model: there the shifts vary slowly against the drives, which
/// that model follows, and the dynamic one would couple every sample with dozens of points. The
/// step is the command shift itself (the dynamics are in the model: no lag is added, no
/// smoothing), so a corner's transient, which varies faster than the quasi-static model can
/// follow, is corrected by the pieces around it.
///
/// The caller (compensate_contour.cpp) simulates the written trial commands, takes each run's step
/// only where its simulated figures stay within those of the program as received and their
/// merit falls, and halves it otherwise.

#include <vector>

#include "postproc/contour/simulate.hpp"

namespace postproc::contour {

struct LearningOptions {
  /// Accepted steps per run at most (0: no refinement).
  int max_iterations = 16;
  /// Halvings of a run's step after a trial that did not improve it, before the run stops.
  int max_halvings = 2;
  /// L of the orientation rows, mm per rad.
  double orientation_length_mm = 100;
  /// Smoothing time as a fraction of the slowest drive's lag time (PrecompensateOptions::smoothing).
  double smoothing = 0.5;
  /// Levenberg–Marquardt damping: added to the normal equations' diagonal, relative to it.
  double damping = 1e-2;
  /// A run stops when an accepted step lowers its merit (compensate_contour.cpp: the four figures,
  /// each relative to the box's, summed) by less than this fraction.
  double relative_tolerance = 0.002;
  /// The samples' dependence on the shifts through the drives' responses (above) rather than the
  /// quasi-static (1 − f)·x_a + f·x_b.
  bool dynamic = true;
};

/// The normal equations of a correction of the path's correctable end points, gathered from the
/// samples of a simulation of `path`'s commands (or of a program with the same points).
class SampleEquations {
 public:
  /// `dynamic`: the drives' responses couple the points (LearningOptions::dynamic); needs samples
  /// that carry their time and path (SampleVisit::t, path), others are taken quasi-statically.
  SampleEquations(const Path& path, double orientation_length_mm, bool dynamic = false);
  /// Weights of run r's tool-tip rows and tool-axis rows (default 1 and 1): e.g. the inverse of
  /// the run's RMS of each, so that the least squares lowers both in proportion rather than
  /// trading one for the other.
  void weigh(std::size_t run, double tip, double axis);
  /// Adds one sample (pass as SimulateOptions::visit).
  void add(const SampleVisit& s);
  /// Forgets every sample.
  void clear();
  /// Takes run `run`'s equations from `other` (gathered on the same path).
  void take_run(const SampleEquations& other, const Run& run);
  /// The step of run `run`'s correctable points into `step` (other points untouched): the damped
  /// least-squares shifts, smoothed along the run, with the drives' lag of the shift added.
  void solve(const Run& run, const LearningOptions& opt, std::vector<kin::JointVector>& step) const;

 private:
  const Path* path_;
  double length_;
  int n_;
  std::vector<char> correctable_;  ///< per path point
  std::vector<double> weight_tip_, weight_axis_;  ///< per run
  std::vector<double> diag_;       ///< per point: n × n block Σ w²·AᵀA (column-major)
  std::vector<double> off_;        ///< per point i: n × n block Σ w_i·w_{i+1}·AᵀA, coupling i and i + 1
  std::vector<double> grad_;       ///< per point: n-vector Σ w·Aᵀε
  std::vector<char> dynamic_at_;   ///< per point: its run uses the dynamic model (asked for, and the run's points sparse enough)
  /// Dynamic model: per point i, the n × n blocks coupling i with i + 1, i + 2, … (as far as a
  /// sample has coupled them), column-major, one after the other.
  std::vector<std::vector<double>> band_;
  double horizon_ = 0;             ///< s: a ramp response differs from its asymptote by < 4e-4 of its lag after this
  void add_dynamic(const SampleVisit& s, const double* rows, const double* eps);
  void solve_dynamic(const Run& run, const LearningOptions& opt, const std::vector<std::size_t>& idx,
                     std::vector<kin::JointVector>& step) const;
};

}  // namespace postproc::contour
