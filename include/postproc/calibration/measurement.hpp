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
/// Header settings ('# key: value' lines before the column header; an unknown key is an error):
/// `kind`, `frame` (`workpiece`, the default, or `instrument [NAME]`), `registration` (the
/// instrument-frame components to estimate), `sigma` (length uncertainty, e.g. `1 um`),
/// `sigma_angle` (e.g. `2 arcsec`); informational: note, comment, description, date, operator,
/// instrument, temperature, noise, source.

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
  /// One direction cosine of the tool axis, `cosine` = d·O with d = measured.r.col(0) (a unit
  /// travel direction): a dial-indicator record without its partners (attitudes files).
  axis_cosine,
};
[[nodiscard]] std::string_view to_string(MeasurementKind k);

/// Registration components of an instrument frame, as bits of Source::free.
enum RegistrationBit : std::uint8_t { kTx = 1, kTy = 2, kTz = 4, kRx = 8, kRy = 16, kRz = 32 };
inline constexpr std::uint8_t kTranslation = kTx | kTy | kTz;
inline constexpr std::uint8_t kRotation = kRx | kRy | kRz;
/// "tx", "ty", "tz", "rx", "ry", "rz" for component k (0…5).
[[nodiscard]] std::string_view registration_name(int k);

/// Where a file's values are and how well they are known (its header settings).
struct Source {
  /// Empty: the values are in the workpiece frame. Otherwise the instrument frame they are in (the
  /// file's path, or the NAME of `# frame: instrument NAME`, shared by the files that name it):
  /// P_workpiece = R·P_instrument + t and R_workpiece = R·R_instrument, R and t estimated with the
  /// machine's parameters (identify.hpp).
  std::string frame;
  std::uint8_t free = 0;  ///< registration components estimated (RegistrationBit)
  double sigma_mm = 0;    ///< `# sigma:` standard uncertainty of every length value, mm; 0: not given
  double sigma_rad = 0;   ///< `# sigma_angle:` standard uncertainty of every angle, rad; 0: not given
};

struct Measurement {
  MeasurementKind kind = MeasurementKind::pose;
  kin::JointVector q;       ///< commanded joint values (mm / deg); struts: the recorded strut coordinates
  kin::Pose measured;       ///< measured tool pose, workpiece frame (only the parts the kind has)
  bool has_torsion = true;  ///< pose and struts: measured.r is complete (else only its axis)
  bool validate = false;    ///< held out: not fitted, only checked
  Source source;            ///< the file's frame and uncertainty
  double cosine = 0;        ///< axis_cosine: the measured d·O
  std::string label;        ///< id column, or file:line
  std::string file;
  std::uint64_t line = 0;
};

/// Rows of the residual of one measurement (see identify.hpp): pose 6 / 5, position 3,
/// direction 2, axis cosine 1, struts = joint count.
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

/// The file's frame and uncertainty settings for measurements of `kind` (poses, positions, …);
/// nullopt after reporting a bad or unknown setting (PP-C007, located).
[[nodiscard]] std::optional<Source> measurement_source(CsvTable& table, std::string_view kind);

/// The file's `# kind:`; nullopt when absent (reported) or unknown (reported).
[[nodiscard]] std::optional<std::string> measurement_file_kind(CsvTable& table);

/// A measurement file's text (header comments, header, one row per measurement, full precision)
/// of measurements of one kind, which read_measurements() reads back. Attitudes are written as
/// directions. `comment` lines go first as '#' lines.
[[nodiscard]] std::string write_measurements(std::span<const Measurement> data, const kin::Model& model,
                                             const std::vector<std::string>& comment = {});

}  // namespace postproc::cal
