#pragma once
/// @file
/// The measurement files of one calibration, read as `calibrate` reads them: each file's kind from
/// its header, kinematic measurements into one list (held-out files marked), step-gauge files into
/// the gauge data, and what was read (path, hash, kind, rows) for the reports.

#include <string>
#include <vector>

#include "postproc/calibration/measurement.hpp"
#include "postproc/calibration/report.hpp"
#include "postproc/calibration/step_gauge.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/kinematics/model.hpp"

namespace postproc::cal {

struct MeasurementFiles {
  std::vector<Measurement> data;  ///< kinematic measurements, held-out ones marked `validate`
  StepGaugeData gauge;            ///< the step-gauge files' readings
  bool have_gauge = false;        ///< a step-gauge file was read
  std::vector<InputFile> inputs;  ///< every file read without error, in order
};

/// Reads `path` (Error(no_input) when it cannot be read) and adds it to `into`; every problem is
/// a located diagnostic in `sink` and leaves `into` without the file. `validate`: the file is held
/// out (step-gauge files build the map and cannot be: PP-C006 at the header).
void add_measurement_file(const std::string& path, bool validate, const kin::Model& model, MeasurementFiles& into,
                          gcode::DiagnosticSink& sink);

}  // namespace postproc::cal
