#pragma once
// Lathe threading cycles: the pass plan a controller cuts for one threading-cycle block (depth of
// each pass, infeed along the flank, spring passes, entry/exit tapers and chamfers).
//
// Everything here is in program units with X as a radius (the caller halves diameters) and works
// in the ZX plane only: a move is a Z and an X end point and a kind. Synchronised moves carry the
// distance per spindle revolution they run at (the lead, or the taper's lead along its slant).
#include <string>
#include <vector>

namespace postproc::gcode::threading {

struct Move {
  enum class Kind { rapid, synced } kind = Kind::rapid;
  double z = 0, x = 0;  ///< end point (x: radius)
  double lead = 0;      ///< synced: distance per revolution
};

/// LinuxCNC G76 (linuxcnc.org/docs/html/gcode/g-code.html#gcode:g76), after the block's checks.
struct LinuxcncG76 {
  double start_z = 0, start_x = 0;  ///< the current point: start of the drive line
  double end_z = 0;                 ///< Z end of the drive line (the block's Z end point)
  double pitch = 0;                 ///< P
  double i = 0, j = 0, k = 0;       ///< radius values (halved under G7)
  bool has_q = false, has_r = false, has_e = false, has_l = false;
  double q = 0;                     ///< compound slide angle, degrees
  double r = 1;                     ///< depth degression
  long h = 0;                       ///< spring passes
  double e = 0;                     ///< taper length along the drive line
  long l = 0;                       ///< 1 entry taper, 2 exit taper, 3 both
};

/// The moves of the passes, up to (not including) the final rapid to the block's end point.
/// Returns an empty string, or why the plan is not made (more passes than this version follows).
std::string plan_linuxcnc_g76(const LinuxcncG76& c, std::vector<Move>& out);

/// Fanuc G92 (system A; G78 in system B) thread cutting cycle, one pass (B-64304EN / B-64484EN,
/// "Thread cutting cycle"): from the start point A rapid to X, threading to Z (along the taper
/// R), rapid out to the start X, rapid back to the start Z. Thread chamfering amount 0 (none).
struct FanucG92 {
  double start_z = 0, start_x = 0;  ///< start point (radius)
  double end_z = 0, end_x = 0;      ///< the cycle's X/Z (end of the thread), radius
  double taper = 0;                 ///< R: radius at the start of the thread minus that at its end
  double lead = 0;                  ///< F
};
void plan_fanuc_g92(const FanucG92& c, std::vector<Move>& out);

}  // namespace postproc::gcode::threading
