#pragma once
/// @file
/// Calibration measurements and their files (docs/measurements.md). A measurement is what the
/// machine was commanded to (joint values) and what an instrument saw; identify() compares it with
/// a model's prediction. Files are CSV (csv.hpp) with a `# kind: …` header comment:
/// - `poses`: joints + tool tip x y z + tool axis i j k (5-DoF), + tool reference direction ui uj uk
///   (6-DoF: the tool frame's x axis, so the rotation about the tool axis is measured too);
/// - `positions`: joints + tool tip x y z (laser tracker, sphere centre, R-test);
/// - `directions`: joints + tool axis i j k;
/// - `attitudes`: joints + dial-indicator records (document 000): per linear axis the travel and
///   the stem extension, giving the direction cosines of the stem (= −tool axis);
/// - `struts` (hexapod): the strut coordinates the NC recorded (the joints) with the known tool
///   pose the setting tool was placed at (x y z, i j k, ui uj uk) (document 003).
/// Optional columns: `id` (a label for reports), `set` (`fit` or `validate`: held-out data).

#include <optional>
#include <span>
#include <string>
#include <vector>

#include "postproc/calibration/csv.hpp"
#include "postproc/kinematics/model.hpp"

namespace postproc::cal {

enum class MeasurementKind : std::uint8_t {
  pose,       ///< tool tip and tool axis (has_torsion: and the rotation about it)
  position,   ///< tool tip only
  direction,  ///< tool axis only (also from dial-indicator attitudes)
  struts,     ///< joint (strut) values recorded at a known tool pose; compared in joint space
};
[[nodiscard]] std::string_view to_string(MeasurementKind k);

struct Measurement {
  MeasurementKind kind = MeasurementKind::pose;
  kin::JointVector q;       ///< commanded joint values (mm / deg); struts: the recorded strut coordinates
  kin::Pose measured;       ///< measured tool pose, workpiece frame (only the parts the kind has)
  bool has_torsion = true;  ///< pose and struts: measured.r is complete (else only its axis)
  bool validate = false;    ///< held out: not fitted, only checked
  std::string label;        ///< id column, or file:line
  std::string file;
  std::uint64_t line = 0;
};

/// Rows of the residual of one measurement (see identify.hpp): pose 6 / 5, position 3,
/// direction 2, struts = joint count.
[[nodiscard]] int residual_rows(const Measurement& m, int joints);

/// The joint columns of a file: one per model joint, named like the joint, with a length unit
/// (linear joints) or an angle unit (rotary joints); missing or wrongly united ones are reported.
struct JointColumns {
  std::vector<int> column;    ///< per joint, -1 when missing or bad
  std::vector<double> scale;  ///< to mm / degrees
  std::vector<kin::Joint> joints;  ///< the model's joints (names, travel limits)
  [[nodiscard]] bool ok() const {
    for (int c : column)
      if (c < 0) return false;
    return true;
  }
};
[[nodiscard]] JointColumns joint_columns(CsvTable& table, const kin::Model& model);
/// The joint values of one row (mm / degrees); nullopt after reporting a bad cell.
[[nodiscard]] std::optional<kin::JointVector> joints_of_row(CsvTable& table, const JointColumns& c, std::size_t row);

/// Reads the measurements of one parsed file for `model` (its joint names are the joint
/// columns). Reports located diagnostics (PP-C0xx) and returns false on any error; appends to out.
bool read_measurements(CsvTable& table, const kin::Model& model, std::vector<Measurement>& out);

/// The file's `# kind:`; nullopt when absent (reported) or unknown (reported).
[[nodiscard]] std::optional<std::string> measurement_file_kind(CsvTable& table);

/// A measurement file's text (header comments, header, one row per measurement, full precision)
/// of measurements of one kind, which read_measurements() reads back. Attitudes are written as
/// directions. `comment` lines go first as '#' lines.
[[nodiscard]] std::string write_measurements(std::span<const Measurement> data, const kin::Model& model,
                                             const std::vector<std::string>& comment = {});

}  // namespace postproc::cal
