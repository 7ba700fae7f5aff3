// Lathe threading cycles: pass plans (LinuxCNC G76; Fanuc G92/G78 and two-block G76).
#include "src/gcode/threading_cycles.hpp"

#include <cmath>
#include <numbers>

namespace postproc::gcode::threading {
namespace {

constexpr long kMaxPasses = 10000;

std::string fmt_passes() {
  return "the cycle makes more than " + std::to_string(kMaxPasses) +
         " passes (depth degression R or spring passes H very large)";
}

}  // namespace

std::string plan_linuxcnc_g76(const LinuxcncG76& c, std::vector<Move>& out) {
  // LinuxCNC G-code reference, "G76 Threading Cycle", as LinuxCNC's interpreter cuts it (checked
  // move for move with rs274 -g, tests/rs274_compare.sh). Depths are measured from the drive line
  // (the start X) towards the thread: the peak at |I|, the first pass |I|+|J|, pass n at
  // |I| + |J|·n^(1/R) while that stays short of the full depth |I|+|K|, then the full depth once
  // and H more times (spring passes). A positive I (inside thread) cuts towards +X.
  const bool inside = c.i > 0;
  const double peak = std::abs(c.i), first = std::abs(c.j), height = std::abs(c.k);
  const double full = peak + height;
  // Compound slide angle Q (rs274 takes an absent Q, and Q-1, as 0), mirrored for a thread cut
  // towards +Z; each pass starts (depth − peak)·tan(Q) further back along the drive line.
  double angle = c.has_q && c.q != -1 ? c.q * std::numbers::pi / 180.0 : 0.0;
  const bool towards_plus = c.end_z > c.start_z;
  if (towards_plus) angle = -angle;
  const double degression = c.has_r && c.r >= 1.0 ? c.r : 1.0;
  double taper = c.has_e && c.e > 0 ? c.e : 0.0;
  // A taper runs the full thread height over E: its lead along Z stays the pitch, so the
  // synchronised rate along the slant is pitch·√(E² + K²)/E.
  const double taper_lead = taper > 0 ? c.pitch * std::hypot(taper, height) / taper : c.pitch;
  if (towards_plus) taper = -taper;
  const long flags = c.has_l && c.l > 0 ? c.l : 0;
  const bool entry = taper != 0 && (flags & 1) != 0, exit = taper != 0 && (flags & 2) != 0;
  const double target_z = c.end_z + height * std::tan(angle);
  const auto x_at = [&](double depth) { return inside ? c.start_x + depth : c.start_x - depth; };
  const auto pass = [&](double depth) {
    const double zoff = (depth - peak) * std::tan(angle);
    const double z0 = c.start_z - zoff, z1 = target_z - zoff;
    const double clear = x_at(depth - full);  // the retract line: the drive line for the last passes
    out.push_back({Move::Kind::rapid, z0, clear, 0});
    if (entry) {
      out.push_back({Move::Kind::synced, z0, x_at(depth - height), taper_lead});
      out.push_back({Move::Kind::synced, z0 - taper, x_at(depth), taper_lead});
    } else {
      out.push_back({Move::Kind::rapid, z0, x_at(depth), 0});
    }
    if (exit) {
      out.push_back({Move::Kind::synced, z1 + taper, x_at(depth), c.pitch});
      out.push_back({Move::Kind::synced, z1, x_at(depth - height), taper_lead});
    } else {
      out.push_back({Move::Kind::synced, z1, x_at(depth), c.pitch});
    }
    out.push_back({Move::Kind::rapid, z1, clear, 0});
  };
  // A large degression or H makes very many passes (rs274 cuts them all); past kMaxPasses this
  // version stops following rather than producing millions of moves.
  long passes = 0;
  double depth = peak + first;
  for (long n = 1; depth < full;) {
    if (++passes > kMaxPasses) return fmt_passes();
    pass(depth);
    depth = peak + first * std::pow(static_cast<double>(++n), 1.0 / degression);
  }
  if (c.h + passes > kMaxPasses) return fmt_passes();
  for (long n = 0; n < c.h + 1; ++n) pass(full);
  return {};
}

void plan_fanuc_g92(const FanucG92& c, std::vector<Move>& out) {
  // Operations 1-4 of the straight / taper threading cycle: the taper R is the radius of the
  // thread at its start minus that at its end (the end is the block's X Z).
  out.push_back({Move::Kind::rapid, c.start_z, c.end_x + c.taper, 0});
  out.push_back({Move::Kind::synced, c.end_z, c.end_x, c.lead});
  out.push_back({Move::Kind::rapid, c.end_z, c.start_x, 0});
  out.push_back({Move::Kind::rapid, c.start_z, c.start_x, 0});
}

}  // namespace postproc::gcode::threading
