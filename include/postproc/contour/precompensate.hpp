#pragma once
/// @file
/// Contour precompensation (docs/contour.md "Precompensation"), run by run.
///
/// Runs are independent (each starts and ends at rest), so each run is iterated on its own:
/// 1. the per-point joint shift d_i that moves the predicted actual pose onto the intended pose at
///    its foot (damped least squares through the pose Jacobian, predict.hpp's errors);
/// 2. the shifts of the run smoothed jointly along the run: per joint, the x minimising
///    Σ(x_i − d_i)² + Σ(τ²·D²x_i)² (D² the second divided difference in time, τ the smoothing
///    time), a pentadiagonal solve; the correction cannot alternate in sign from block to block;
/// 3. the drives' lag of the update added (δ = x + e₁·ẋ), the trial commands c + α·δ predicted
///    for the run alone; a trial that makes the run worse (its largest error, tip + L·axis, or its
///    RMS grows) is not taken: the step α is halved and retried (a bounded number of times),
///    then the run stops with "no improvement". The best iterate of every run is kept.
/// Where the iteration from the program ends predicted worse than the lag precompensation
/// (below), the run is iterated again from that, and the better iterate is kept. A run stops
/// "converged" when an accepted step improves both its largest error and its RMS by
/// less than the tolerance, "cap" at the iteration limit.
///
/// Besides the iterated commands, the classic first-order lag precompensation is computed as a
/// baseline and a candidate: every joint command at a block end point advanced by the drive's
/// quasi-static following error there (drive.hpp; lag_precompensation below). The verification gate
/// (compensate_contour.cpp) writes, per run, the best of {uncorrected, lag, iterated} as the
/// time-domain simulation judges them.

#include <cstdint>
#include <string_view>
#include <vector>

#include "postproc/contour/predict.hpp"
#include "postproc/progress.hpp"

namespace postproc::contour {

struct PrecompensateOptions {
  /// Accepted iterations per run at most.
  int max_iterations = 12;
  /// A run has converged when an accepted step improves its largest error (tip + L × axis, mm)
  /// by less than this, mm …
  double tolerance_mm = 1e-6;
  /// … or both its largest error and its RMS by less than this fraction of themselves.
  double relative_tolerance = 0.05;
  /// Halvings of the step tried after a trial that made the run worse, before the run stops.
  int max_halvings = 4;
  /// L of the orientation rows, mm per rad.
  double orientation_length_mm = 100;
  /// Relative singular-value cut of the pseudo-inverse.
  double rcond = 1e-6;
  /// Smoothing time τ of the correction along the run, as a fraction of the slowest drive's lag
  /// time e₁ = (1 − f)/Kv (0: no smoothing). Components of the correction faster than about
  /// 1/τ are damped.
  double smoothing = 0.5;
  /// Add the drives' lag of the correction itself to the commands (δ = d + e₁·ḋ), so that the
  /// actual joints move by d: fewer iterations.
  bool invert_lag = true;
  /// Accepted steps per run of the refinement on the time-domain simulation after the
  /// verification (learning_control.hpp; compensate_contour.cpp runs it), 0: none.
  int learning_iterations = 16;
  /// Told "contour: correcting" with the runs done of the runs (optional).
  Progress progress;
};

/// Why the iteration of a run stopped.
enum class RunStop : std::uint8_t {
  nothing,         ///< nothing to correct (no correctable point, or no error)
  converged,       ///< the last accepted step improved the run by less than the tolerance
  no_improvement,  ///< no trial step (after the halvings) made the run better
  cap,             ///< the iteration limit was reached while the run still improved
};
[[nodiscard]] std::string_view to_string(RunStop s);

/// The iteration of one run (predicted figures, mm / rad).
struct RunIteration {
  int iterations = 0;  ///< accepted iterations
  int trials = 0;      ///< predictions of trial commands (accepted or not)
  RunStop stop = RunStop::nothing;
  bool from_lag = false;  ///< the kept iterate started from the lag precompensation
  double before_tip_mm = 0, before_axis_rad = 0, before_rms_mm = 0;
  double after_tip_mm = 0, after_axis_rad = 0, after_rms_mm = 0;
  std::vector<double> history_mm;   ///< largest tip error after each accepted iteration
  std::vector<double> history_rad;  ///< … tool axis
};

struct Precompensation {
  std::vector<kin::JointVector> commands;      ///< iterated commands per path point (the best iterate of each run)
  std::vector<kin::JointVector> lag_commands;  ///< first-order lag precompensation per path point
  Prediction before;
  Prediction after;                            ///< of `commands`
  std::vector<RunIteration> runs;              ///< per run of the path
  int iterations = 0;                          ///< the most accepted iterations of a run
  bool converged = false;                      ///< no run stopped at the iteration limit
  /// Largest tip error over the program after k accepted iterations (a run that stopped earlier
  /// counts with its final value), mm …
  std::vector<double> history_mm;
  std::vector<double> history_rad;             ///< … tool axis, rad
};

/// Corrects every block end point of the path except the runs' last points (the machine stops and
/// settles on those commands, so they stay as programmed); run starts and arc chord points keep
/// their commands as well (they are not written words of the program).
[[nodiscard]] Precompensation precompensate(const Path& path, const kin::Model& actual, const Reference& ref,
                                            const PrecompensateOptions& opt = {});

/// The first-order lag precompensation of the path's commands: at every correctable point (as
/// above) each joint command advanced by its drive's quasi-static following error — that of the
/// advanced command itself, c = r + e(c), which to second order is e₁·ṙ + (e₂ + e₁²)·r̈ (for a
/// lag-mode drive exactly ṙ/Kv) — with ṙ and r̈ the commanded velocity and acceleration there
/// (central differences over the neighbouring points' times).
[[nodiscard]] std::vector<kin::JointVector> lag_precompensation(const Path& path);

/// The point is a written block end point that the precompensation may move (not a run's first
/// or last point, not an arc's point nor the start of an arc).
[[nodiscard]] bool correctable(const Path& path, const Run& run, std::size_t i);

}  // namespace postproc::contour
