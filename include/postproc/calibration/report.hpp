#pragma once
/// @file
/// The calibration report: what was identified from which data, how well (identifiability,
/// standard deviations), and the residuals before/after per measurement for the fitted and the
/// held-out (validation) measurements. JSON for scripts, one self-contained HTML file (inline
/// SVG residual plot, no network resources) for people.

#include <span>
#include <string>
#include <vector>

#include "postproc/calibration/identify.hpp"
#include "postproc/calibration/step_gauge.hpp"

namespace postproc::cal {

struct InputFile {
  std::string path;
  std::string sha256;
  std::string kind;  ///< poses, positions, …
  std::size_t measurements = 0;
};

/// Residual figures of one measurement set before and after.
struct SetFigures {
  std::size_t count = 0;
  std::size_t positions = 0;  ///< measurements with a tool-tip (or strut) error
  std::size_t angles = 0;     ///< measurements with a tool-axis error
  double max_position_before_mm = 0, max_position_after_mm = 0;
  double rms_position_before_mm = 0, rms_position_after_mm = 0;
  double max_angle_before_deg = 0, max_angle_after_deg = 0;
};

struct CalibrationRun {
  std::string tool_version;
  std::string machine_file, machine_sha256, machine_name, output_file;
  std::vector<InputFile> inputs;
  IdentifyOptions options;
  IdentifyResult result;
  const kin::Model* start = nullptr;   ///< the model the data was fitted from
  const kin::Model* solved = nullptr;  ///< the identified model
  std::span<const Measurement> data;   ///< fitted and held-out measurements
  std::vector<std::string> notes;      ///< extra lines (e.g. the step-gauge map summary)
  /// The step-gauge map built by this run (optional): the reports plot it and say how well each
  /// pyramid's error is determined.
  const StepGaugeReport* step_gauge = nullptr;
};

/// Per measurement errors before/after (measurement_error()) and the per-set figures.
struct Comparison {
  std::vector<MeasurementError> before, after;
  SetFigures fit, validation;
};
[[nodiscard]] Comparison compare(const CalibrationRun& run);

/// Status of parameter k in the reports: "identified" (estimated, and its ±1σ small against its
/// change from the drawing — at least 2σ away — or at most 1 µm / 1 arcsec / 1 µm/m), "poorly
/// determined" (estimated and used, but the data do not pin it down), "unidentifiable" (held at
/// its start value) or "fixed" (not asked for).
[[nodiscard]] std::string parameter_status(const CalibrationRun& run, int k);

[[nodiscard]] std::string report_json(const CalibrationRun& run);
[[nodiscard]] std::string report_html(const CalibrationRun& run);

}  // namespace postproc::cal
