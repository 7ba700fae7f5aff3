#pragma once
/// @file
/// Time-domain simulation (issue 6): the controller's discrete interpolator (path.hpp) samples the
/// commands at the interpolation period, every joint's closed-loop drive (drive.hpp, integrated
/// exactly per period) follows them, and the actual pose FK(y) at every period is measured against
/// an intended contour (reference.hpp) — independently of the quasi-static prediction.

#include <cstdint>
#include <functional>
#include <vector>

#include "postproc/contour/path.hpp"
#include "postproc/contour/reference.hpp"

namespace postproc::contour {

/// One simulated sample as SimulateOptions::visit sees it (references valid during the call).
struct SampleVisit {
  std::size_t run = 0;
  std::size_t segment = 0;  ///< the path point the command moves toward (Sample::segment)
  double fraction = 0;      ///< how far along that segment the command is, 0…1
  const kin::JointVector& actual;  ///< the drives' actual joints, mm / degrees
  const kin::Model& model;         ///< the calibrated model of the segment's controller context
  const ContourError& error;       ///< the actual pose's contour error against the reference
  double t = 0;                    ///< the sample's time on the simulated path's clock (Path::points[i].t), s
  const Path* path = nullptr;      ///< the simulated path (its point times), when the simulator gives it
};

struct SimulateOptions {
  double settle_s = 0.1;       ///< time simulated at rest after each run's end, s
  std::size_t keep_every = 0;  ///< keep every k-th sample in Simulation::samples (0: none)
  /// Called with every sample (optional): e.g. to gather the normal equations of a correction
  /// (learning_control.hpp) without keeping the samples.
  std::function<void(const SampleVisit&)> visit;
  /// Runs to simulate (optional; indexed like Path::runs, non-zero: simulated): the figures of the
  /// others stay 0 and their time is not counted (Simulation::samples, SimSample::t).
  const std::vector<char>* only_runs = nullptr;
};

struct SimSample {
  double t = 0;               ///< s, from the start of the program's first run; runs follow each other
                              ///< on the interpolation grid (a run's first sample one period after the
                              ///< previous run's last settling sample), so t = sample index × period
  std::size_t run = 0;
  std::uint64_t line = 0;     ///< source line of the segment being interpolated
  kin::JointVector command;   ///< mm / degrees
  kin::JointVector actual;    ///< mm / degrees
  Eigen::Vector3d tip = Eigen::Vector3d::Zero();  ///< actual tool tip, mm
  double tip_mm = 0;          ///< tool-tip contour error, mm
  double axis_rad = 0;        ///< tool-axis contour error, rad
};

struct Simulation {
  Summary tip;                       ///< mm, over every sample
  Summary axis;                      ///< rad
  std::vector<double> max_following; ///< per joint, mm / degrees
  std::uint64_t samples = 0;
  std::uint64_t worst_tip_line = 0;  ///< source line at the largest tip error
  std::uint64_t worst_axis_line = 0;
  std::vector<double> run_tip_max;   ///< per run of the commanded path: largest tool-tip error, mm
  std::vector<double> run_axis_max;  ///< per run: largest tool-axis error, rad
  std::vector<double> run_tip_rms;   ///< per run: RMS of the tool-tip error over its samples, mm
  std::vector<double> run_axis_rms;  ///< per run: RMS of the tool-axis error, rad
  std::vector<SimSample> kept;
};

/// Simulates `commanded` (the program that runs) and measures against `ref` (the intended contour,
/// usually built from the original program's path; `commanded` may be that same path). The runs of
/// the two paths correspond one to one (same number of runs). Within a run the foot is searched
/// along the path (docs/contour.md, time-domain simulation): the commanded pose's place on the
/// reference advances monotonically (from the interpolator's segment when the runs have as many
/// points, then tracked forward, so the point counts may differ, e.g. subdivided moves), and the actual pose's foot is
/// searched within 2·(|actual − command| + the command's distance to the reference) + 5 µm of arc
/// around it (Reference::error_within), so a neighbouring pass nearer in space is not taken. Each run
/// starts with every drive at rest on the run's first command; the acceleration handed to the
/// drives' feed-forward is the second difference of the last three command samples. Throws
/// postproc::Error: usage when the numbers of runs differ (or the joints / drives do not match
/// the model), refused when the actual model's forward kinematics fails at a sample.
[[nodiscard]] Simulation simulate(const Path& commanded, const Reference& ref, const kin::Model& actual,
                                  const SimulateOptions& opt = {});

}  // namespace postproc::contour
