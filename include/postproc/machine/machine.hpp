#pragma once
/// @file
/// Machine files (TOML, schema in docs/machine-file.md): the controller dialect, what the
/// program's axis words carry, how F is read, the calibrated (actual) and nominal kinematic
/// models, axis travel, output decimals, work offsets, tool lengths and the servo data of each
/// axis. Loading validates everything and reports located diagnostics (codes PP-M…).

#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "postproc/gcode/diagnostic.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/motion.hpp"
#include "postproc/kinematics/model.hpp"

namespace postproc::machine {

/// What the program's axis words carry.
enum class ProgramCoordinates : std::uint8_t {
  axes,      ///< machine axis positions (plus work offset and tool length); TCP blocks are tool-tip anyway
  tool_tip,  ///< tool-tip point and tool orientation in the workpiece frame (parallel machines)
};

/// How a tool-tip program states the tool orientation.
enum class Orientation : std::uint8_t {
  rotary_axes,  ///< the machine's rotary axis values (Fanuc G43.4, TRAORI with A B C, M128)
  vector,       ///< a tool vector: Fanuc G43.5 I J K, Siemens A3 B3 C3
  virtual_ab,   ///< virtual angles A, B (deg): O = Rx(A)·Ry(B)·ẑ (parallel heads)
};

/// What an F word (per minute) measures.
/// Which of the two inverse-kinematics solutions of a serial machine with two rotary axes the
/// controller takes for a tool-tip program with a tool axis (TRAORI with vectors, M128 / TCPM with
/// LN vectors, G43.5): the two differ in the sign of the tilting axis (the one that flips sign
/// between them; the other turns by half a turn).
enum class IkBranch : std::uint8_t {
  nearest,        ///< the solution nearest the joints of the block before (postproc's former fixed rule)
  tilt_positive,  ///< the tilting axis at a positive angle (where it is not 0)
  tilt_negative,  ///< the tilting axis at a negative angle
  /// Of the solutions whose rotary axes lie within their travel (each turn of a rotary axis with
  /// limits counted), the one nearest the joints of the block before; none within travel: the
  /// controller stops (Heidenhain PLANE without SEQ; Beckhoff TF5200 P-CHAN-00189 mode 2).
  nearest_in_travel,
};
[[nodiscard]] std::string_view to_string(IkBranch b);

enum class FeedReference : std::uint8_t {
  tool_tip,       ///< path speed of the tool tip in the workpiece frame (TCP, parallel machines)
  combined_axes,  ///< √Σ axis rates² with degrees counted as mm (Fanuc/Siemens without TCP)
};

/// Per program axis: output and servo data (the servo data is used by `predict`/contour work).
struct AxisSettings {
  int decimals = 3;                          ///< decimals written for this axis
  std::optional<double> kv;                  ///< position-loop gain, 1/s
  double feed_forward = 0;                   ///< velocity feed-forward fraction 0…1
  double acceleration_feed_forward = 0;      ///< 0…1
  std::optional<double> velocity_loop_time;  ///< equivalent velocity-loop time constant, s
  std::optional<double> max_velocity;        ///< mm/min (deg/min for rotary axes)
  std::optional<double> max_acceleration;    ///< mm/s² (deg/s²)
  std::optional<double> max_jerk;            ///< mm/s³ (deg/s³)
};

/// How the interpolator treats a junction of two moves in continuous-path mode ([interpolator]
/// corner, docs/contour.md "Corners").
enum class CornerRule : std::uint8_t {
  time,       ///< every joint's velocity jump at the junction ≤ max_acceleration · corner_time (Fanuc 1783)
  tolerance,  ///< a blend arc deviating at most corner_tolerance from the corner (G64 P, G642, CYCLE 32 T)
  distance,   ///< a blend arc starting corner_distance before the corner (Siemens G641 ADIS=, program only)
};

/// The controller's interpolator ([interpolator] table): corner behaviour in continuous-path mode.
/// The program's own blending words (LinuxCNC G64 P, Siemens G641 ADIS= / G642) override it per run.
struct InterpolatorSettings {
  CornerRule corner = CornerRule::time;
  double corner_time = 0.005;        ///< s (corner = time)
  double corner_tolerance = 0.01;    ///< mm (corner = tolerance, and Siemens G642 without CTOL=)
};

/// [uncertainty] (written by `postproc calibrate`): how well the calibration knows the machine.
struct Uncertainty {
  std::vector<int> parameters;  ///< indices into actual->parameters() of the identified parameters
  Eigen::MatrixXd covariance;   ///< their covariance, in the parameters' units (mm, rad)
  /// Per joint of the model (mm / degrees): the range the fitted measurements covered; empty when
  /// the file does not say. Outside it a correction extrapolates the calibration.
  std::vector<double> region_min, region_max;
};

struct Machine {
  std::string file;        ///< path as given
  std::string sha256;      ///< of the file's bytes, lowercase hex
  std::string name;
  std::string dialect_name;  ///< as written: fanuc, siemens, linuxcnc, heidenhain-iso
  gcode::DialectOptions dialect_options;
  std::string model_kind;  ///< serial, prs-hybrid, hexapod
  ProgramCoordinates coordinates = ProgramCoordinates::axes;
  Orientation orientation = Orientation::rotary_axes;
  FeedReference feed = FeedReference::combined_axes;
  double interpolation_period = 0.001;  ///< s
  /// The largest rotary-joint correction the geometric remap may use to correct the tool axis, rad
  /// ([machine] max_rotary_correction): near a singular pose the tool axis is corrected only as
  /// far as this allows (kinematics/bounded_inverse.hpp); the tool tip is always corrected.
  double max_rotary_correction_rad = 0.017453292519943295;  // 1°
  /// [machine] ik_branch: the controller's choice between the two solutions of a tool axis.
  IkBranch ik_branch = IkBranch::nearest;
  /// The program axis that is the workpiece spindle of a mill-turn ([machine] turning_spindle,
  /// e.g. C), -1 for none: while the spindle turns (M3 / M4) it is not a position, a block is a
  /// turning move whose tool-tip radius and Z are what the program means.
  int turning_spindle_axis = -1;
  /// [interpolator]: the corner behaviour of the controller's interpolator.
  InterpolatorSettings interpolator;
  /// Program axes the machine has (index gcode::Axis), with their settings.
  std::array<std::optional<AxisSettings>, gcode::kAxisCount> axes;
  /// Servo data of joints that are not program axes (parallel machines: "q1" …), from
  /// [drives.<joint>]; `decimals` is unused there.
  std::map<std::string, AxisSettings> drives;
  kin::ModelPtr actual;   ///< the calibrated machine (with its volumetric map, if any)
  kin::ModelPtr nominal;  ///< the controller's model: the drawing, no errors, no map
  /// Work offsets by name ("G54", "G55", … "G54.1P1", "G59.1"): mm / degrees per axis.
  std::map<std::string, gcode::AxisVector> work_offsets;
  double tool_length = 0;                     ///< mm, when no H/D number names another
  std::map<std::uint32_t, double> tool_lengths;  ///< by H (or D) number, mm
  std::map<std::uint32_t, double> tool_radii;    ///< cutter radius by D number (LinuxCNC: tool number), mm
  /// [uncertainty]: the calibration's covariance and region (none for an uncalibrated file).
  std::optional<Uncertainty> uncertainty;
  /// For serial machines: the joint index of each program axis, -1 if the machine has none.
  std::array<int, gcode::kAxisCount> joint_of_axis{};

  [[nodiscard]] int decimals(int axis) const {
    const auto& a = axes[static_cast<std::size_t>(axis)];
    return a ? a->decimals : 3;
  }
};

/// Name of a work offset as machine files write it: "G54", "G54.1P3", "G59.2".
/// The tool length (mm) a motion runs with: the offset the program itself states (LinuxCNC G43.1 /
/// G43.2 Z, or a length the interpreter took from the tool table), else the machine file's
/// [tool.lengths] entry of its H/D number, else [tool] length when no number is active. nullopt: the
/// motion names a number the machine file does not give.
[[nodiscard]] std::optional<double> tool_length_of(const Machine& m, const gcode::Motion& mo);
/// The refusal of a move whose tool length the program rewrote (G10) to a value not known here.
[[nodiscard]] std::string rewritten_length_refusal(const gcode::Motion& mo);
[[nodiscard]] std::string work_offset_name(const gcode::WorkOffset& w);

/// Parses and validates a machine file's text; nullopt when any error was reported to `sink`.
[[nodiscard]] std::optional<Machine> parse_machine(std::string file, std::string text, gcode::DiagnosticSink& sink);
/// Reads `path` and parses it. Throws postproc::Error (no_input) when it cannot be read.
[[nodiscard]] std::optional<Machine> load_machine(const std::string& path, gcode::DiagnosticSink& sink);

/// SHA-256 of `bytes`, lowercase hex.
[[nodiscard]] std::string sha256_hex(std::string_view bytes);

}  // namespace postproc::machine
