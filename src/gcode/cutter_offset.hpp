#pragma once
/// @file
/// LinuxCNC cutter radius compensation (G41/G42, G41.1/G42.1, G40): the tool-centre path LinuxCNC's
/// interpreter makes of the programmed moves, in the G17 (X Y) or G18 (Z X) plane.
///
/// The rules are LinuxCNC's own (rs274ngc, interp_convert.cc and interp_queue.cc; G-code reference
/// "G41, G42 Cutter Compensation", "G41.1, G42.1 Dynamic Cutter Compensation", user manual "Cutter
/// Radius Compensation"):
/// - The first move after G41/G42 (the entry move) goes to the point one radius beside the programmed
///   end, at right angles to the line from the tool to that end (a straight move), or along an arc
///   about a centre moved so that the arc stays tangent to the tool (an entry arc).
/// - Every later move ends one radius beside its programmed end (at right angles to a straight move,
///   radially for an arc). At an outside corner an arc about the programmed corner is inserted (a
///   rapid gets a straight traverse instead); where the directions differ by no more than 0.05 rad
///   nothing is inserted; at an inside corner the move before it is shortened to where the two
///   offset paths meet (line–line, line–arc, arc–line, arc–arc), which needs the next move: the last
///   move is held until the next one in the plane is known, together with moves that change no
///   in-plane coordinate, which end where the held move ends.
/// - M0, M1, M2, M30, M60 and G40 release the held moves where they end; after G40 the programmed
///   point is the current point again and the next move must be straight.
/// Plane-agnostic as in LinuxCNC: u, v are X, Y in G17 and Z, X in G18 (plane_axes()).
///
/// Lengths are mm; LinuxCNC compares two lengths against constants in program units (its "BUG"
/// checks), for which set_inch() says the units.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "postproc/gcode/motion.hpp"

namespace postproc::gcode {

class CutterOffset {
 public:
  enum class Side : std::int8_t { left = 1, right = -1 };
  /// Why a move is not computed: LinuxCNC stops there with `text` (controller), or this version does
  /// not compute it (the reason).
  struct Refusal {
    std::string text;
    bool controller = true;
  };
  using Outcome = std::optional<Refusal>;

  /// G41/G42 with a radius above 0: the first move is the entry move; the tool centre is at `at`
  /// (LinuxCNC's current point: the programmed point when compensation is off). `orientation` is the
  /// lathe tool orientation (tool table Q, G41.1 L): 1–8 move the controlled point off the nose centre
  /// in G18.
  void start(Side side, double radius_mm, Plane plane, int orientation, const AxisVector& at);
  /// Compensation is off (G40 after flush(), M2/M30), or was never on.
  void stop();
  [[nodiscard]] bool on() const { return on_; }
  [[nodiscard]] bool first_move() const { return first_; }
  /// Moves are held, waiting for the next move to fix their end.
  [[nodiscard]] bool holding() const { return !held_.empty(); }
  [[nodiscard]] Side side() const { return side_; }
  [[nodiscard]] double radius() const { return radius_; }
  /// The tool centre after the moves computed so far (LinuxCNC's current point under compensation).
  [[nodiscard]] const AxisVector& tool() const { return tool_; }
  /// Where the machine is after the last released move (with a lathe tool's controlled point).
  [[nodiscard]] const AxisVector& released_end() const { return released_; }
  void set_inch(bool inch) { unit_ = inch ? 25.4 : 1.0; }
  /// Where the machine is when compensation starts, when it is not the programmed point (after a G40
  /// that left the tool offset).
  void set_released(const AxisVector& at) { released_ = at; }

  /// One programmed move under compensation: a rapid, a straight feed or an arc (`programmed.start`
  /// is the programmed start point, `programmed.arc` the programmed arc). The moves it releases are
  /// appended to `out` in order. Returns why not where the move is refused.
  Outcome move(const Motion& programmed, std::vector<Motion>& out);
  /// M0, M1, M2, M30, M60, G40: the held moves end where they are and are released.
  Outcome flush(std::vector<Motion>& out);
  /// The held moves, not released (the program ends without M2/M30 under compensation: LinuxCNC never
  /// issues them). Compensation stays as it was.
  std::vector<Motion> take_held();

 private:
  struct Held {
    Motion m;                                       ///< end (in the plane: before any lathe shift), state
    Eigen::Vector2d dir = Eigen::Vector2d::Zero();  ///< straight: the direction LinuxCNC keeps for its gouge check
    bool arc = false;
    int turn = 0;                                   ///< arc: turns, + counter-clockwise in (u, v)
    Eigen::Vector2d centre = Eigen::Vector2d::Zero();
    double sweep0 = 0;                              ///< arc: LinuxCNC's "original_turns" (rad), 0 = not checked
  };

  Outcome straight_entry(const Motion& p, std::vector<Motion>& out);
  Outcome straight(const Motion& p, std::vector<Motion>& out);
  Outcome arc_entry(const Motion& p, std::vector<Motion>& out);
  Outcome arc(const Motion& p, std::vector<Motion>& out);
  /// LinuxCNC's move_endpoint_and_flush: every held move now ends at `to`, then all are released.
  Outcome end_held_at(const Eigen::Vector2d& to, std::vector<Motion>& out);
  void release(std::vector<Motion>& out);
  void set_from(const Eigen::Vector2d& p) {
    from_ = p;
    from_valid_ = true;
  }
  void hold_straight(const Motion& p, const Eigen::Vector2d& dir, const Eigen::Vector2d& end, double n_end);
  void hold_arc(const Motion& p, const Eigen::Vector2d& end, const Eigen::Vector2d& centre, int turn, double sweep0,
                double n_end, bool corner);
  [[nodiscard]] Eigen::Vector2d in_plane(const AxisVector& a) const;
  [[nodiscard]] Eigen::Vector2d lathe_shift() const;

  bool on_ = false;
  bool first_ = true;
  Side side_ = Side::left;
  double radius_ = 0;
  int orientation_ = 0;
  Plane plane_ = Plane::xy;
  double unit_ = 1;              ///< mm per program unit
  AxisVector tool_ = AxisVector::Zero();      ///< current tool centre (compensated, before a lathe shift)
  AxisVector released_ = AxisVector::Zero();  ///< end of the last released move (after a lathe shift)
  std::vector<Held> held_;
  Eigen::Vector2d from_ = Eigen::Vector2d::Zero();  ///< LinuxCNC's "endpoint": where the held moves start
  bool from_valid_ = false;
};

/// LinuxCNC's find_turn: the angle (rad, + counter-clockwise) an arc of `turn` turns (sign = direction)
/// sweeps from `a` to `b` about `c`; a full turn when `a` and `b` coincide.
[[nodiscard]] double cutter_turn_angle(const Eigen::Vector2d& a, const Eigen::Vector2d& c, int turn,
                                       const Eigen::Vector2d& b);

}  // namespace postproc::gcode
