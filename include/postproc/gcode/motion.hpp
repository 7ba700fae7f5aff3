#pragma once
/// @file
/// Resolved motion: what one motion of the program does, in absolute mm and degrees, with where it
/// came from and the modal state it ran under.

#include <array>
#include <cstdint>
#include <string_view>

#include <Eigen/Core>

namespace postproc::gcode {

/// Axis order used everywhere: linear X Y Z, rotary A B C, secondary linear U V W.
enum class Axis : std::uint8_t { x, y, z, a, b, c, u, v, w };
inline constexpr int kAxisCount = 9;
inline constexpr std::array<char, kAxisCount> kAxisLetters = {'X', 'Y', 'Z', 'A', 'B', 'C', 'U', 'V', 'W'};
/// Axis position vector: mm for X Y Z U V W, degrees for A B C.
using AxisVector = Eigen::Matrix<double, kAxisCount, 1>;
using AxisMask = std::uint16_t;  ///< bit i set = axis i
[[nodiscard]] constexpr AxisMask bit(Axis a) { return static_cast<AxisMask>(1u << static_cast<int>(a)); }
[[nodiscard]] constexpr bool is_rotary(int axis) { return axis >= 3 && axis <= 5; }
/// Index of an axis letter, -1 if the letter is not an axis.
[[nodiscard]] int axis_index(char upper_letter);

enum class MotionType : std::uint8_t { rapid, linear, arc_cw, arc_ccw, drill_cycle };
enum class Plane : std::uint8_t { xy, zx, yz };
enum class FeedMode : std::uint8_t { per_minute, per_rev, inverse_time };
enum class TcpMode : std::uint8_t {
  off,
  fanuc_g43_4,   ///< Fanuc G43.4 tool-centre point, rotary axes programmed
  fanuc_g43_5,   ///< Fanuc G43.5, tool axis programmed by I J K
  siemens_traori,///< Sinumerik TRAORI
  heidenhain_m128,
};
enum class Frame : std::uint8_t { work, machine };  ///< machine = G53 / SUPA block

/// Axis indices of a plane: first and second in-plane axis (counter-clockwise order seen from the
/// normal's positive side: X→Y for G17, Z→X for G18, Y→Z for G19) and the normal axis.
struct PlaneAxes {
  int u, v, n;
};
[[nodiscard]] constexpr PlaneAxes plane_axes(Plane p) {
  switch (p) {
    case Plane::xy: return {0, 1, 2};
    case Plane::zx: return {2, 0, 1};
    case Plane::yz: return {1, 2, 0};
  }
  return {0, 1, 2};
}

[[nodiscard]] std::string_view to_string(MotionType);
[[nodiscard]] std::string_view to_string(Plane);
[[nodiscard]] std::string_view to_string(FeedMode);
[[nodiscard]] std::string_view to_string(TcpMode);

/// Active work offset: G54–G59 (code10 540…590), G54.1 P n (code10 541, p = n), G59.1…3.
struct WorkOffset {
  std::uint16_t code10 = 540;
  std::uint16_t p = 0;
};

/// Arc geometry in the active work coordinate system (mm).
struct ArcData {
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  double radius = 0;       ///< mm
  double sweep = 0;        ///< signed sweep angle in radians about the plane normal (+ = ccw)
  std::uint32_t turns = 1; ///< full turns requested (P word); 1 = ordinary arc
  bool full_circle = false;
};

/// One resolved motion.
struct Motion {
  std::uint64_t line = 0;        ///< 1-based source line of the block
  std::uint32_t column = 1;      ///< column of the motion word (or of the first axis word)
  MotionType type = MotionType::linear;
  std::uint16_t cycle_code10 = 0;///< G code × 10 of a drilling cycle (810 for G81), 0 otherwise
  double cycle_r = 0;            ///< drilling cycle: retract plane along the plane normal, mm
  double cycle_bottom = 0;       ///< drilling cycle: hole bottom along the plane normal, mm
  Plane plane = Plane::xy;
  Frame frame = Frame::work;
  AxisVector start = AxisVector::Zero();
  AxisVector end = AxisVector::Zero();   ///< absolute, active work coordinates, mm / degrees
  AxisMask known = 0;            ///< axes whose absolute end position is known
  AxisMask programmed = 0;       ///< axes written in this block
  std::array<std::int8_t, kAxisCount> word_index{};  ///< index into Block::words per axis, -1 if none
  ArcData arc;                   ///< valid for arc_cw / arc_ccw
  double feed = 0;               ///< mm/min, mm/rev or 1/min (inverse time); 0 = not set
  FeedMode feed_mode = FeedMode::per_minute;
  bool feed_known = false;
  WorkOffset work_offset;
  AxisVector local_offset = AxisVector::Zero();     ///< G52 / TRANS shift, mm / degrees
  AxisVector position_offset = AxisVector::Zero();  ///< G92 shift, mm / degrees
  /// Axes whose G92 shift is not known (G92 given where the axis's position was unknown): their
  /// work (and machine) position is unknown although the program coordinates are.
  AxisMask position_offset_unknown = 0;
  bool tool_length_active = false;
  /// The spindle turns (M3 / M4 active): on a machine whose C axis is the turning spindle
  /// ([machine] turning_spindle) the block is a turning move, C is not a position.
  bool spindle_turning = false;
  std::uint16_t tool_length_h = 0;  ///< H number (Fanuc), tool number (LinuxCNC G43 / G43 H)
  /// The tool length offset the controller applies, mm, when the program states it exactly (G43.1
  /// Z, H0, G49, or a tool table that knows the number); else compensation looks tool_length_h up.
  double tool_length = 0;
  bool tool_length_known = false;
  /// The program rewrote the length of tool_length_h (G10 L1/L10/L11…) to a value not known here:
  /// the machine file's length for that number is not the controller's.
  bool tool_length_rewritten = false;
  /// The program wrote the table entry of work_offset (G10 L2/L20, or an entry it could not name):
  /// the machine file's offset for that system is not the controller's.
  bool work_offset_rewritten = false;
  /// Axes of work_offset whose table value the program wrote as a plain number (LinuxCNC G10 L2 P…,
  /// Fanuc G10 L2 P1–P6 under G90, no rotation): the controller's offset of those axes is
  /// work_offset_value (mm / degrees, machine coordinates of the origin), not the machine file's.
  AxisMask work_offset_written = 0;
  AxisVector work_offset_value = AxisVector::Zero();
  TcpMode tcp = TcpMode::off;
  bool tilted_plane = false;     ///< G68.2 / CYCLE800 / PLANE active
  /// Tool-axis direction programmed as a vector in this block (Siemens A3/B3/C3 under TRAORI,
  /// Fanuc I J K under G43.5), normalised; valid when tool_vector_known.
  Eigen::Vector3d tool_vector = Eigen::Vector3d::UnitZ();
  bool tool_vector_known = false;
  bool orientation_machine_frame = false;  ///< Siemens ORIMKS (else ORIWKS: workpiece frame)
  bool diameter_mode = false;    ///< X was programmed as a diameter (end holds the radius)
  bool inch_source = false;      ///< the block was programmed in inches (end is converted to mm)
  /// The block's axis words are not the end point in the work frame (Fanuc G16 radius/angle, G51.1
  /// mirrored, G29 through the intermediate point): a writer must not put corrected coordinates in them.
  bool words_transformed = false;
  /// Cutter radius compensation: the radius (mm) by which the controller offsets this motion's
  /// tool-centre path from the programmed contour, 0 = none, NaN = a radius not known (the tool table
  /// does not give it). LinuxCNC (G41/G42, G41.1/G42.1): the motion is the tool-centre path
  /// (words_transformed is set). Fanuc, Sinumerik (G41/G42) and Heidenhain (RL/RR): the offset is not
  /// computed, the motion is the programmed contour. Either way a corrected program would be offset
  /// again by the controller.
  double cutter_radius = 0;
};

/// The direction of motion `m` at its end in X Y Z (not normalised): the chord of a straight move;
/// for an arc the in-plane tangent plus its climb per radian along the plane normal (helix). What a
/// following tangential arc (Sinumerik CT, Klartext CT) continues.
[[nodiscard]] Eigen::Vector3d end_direction(const Motion& m);

}  // namespace postproc::gcode
