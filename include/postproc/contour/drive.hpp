#pragma once
/// @file
/// The servo drive of one axis (issue 6): a proportional position loop with gain Kv, velocity
/// feed-forward fraction f, acceleration feed-forward fraction g and a velocity loop that follows
/// its command with a first-order lag T (the equivalent velocity-loop time constant):
///
///   velocity command  u = Kv·e + f·ṙ + g·T·r̈,   velocity loop  T·ÿ + ẏ = u,   e = r − y,
///
/// r the commanded position, y the actual one (mm or degrees). For a command whose velocity and
/// acceleration change slowly compared with 1/Kv and T, the following error is
///
///   e ≈ e₁·ṙ + e₂·r̈,   e₁ = (1 − f)/Kv,   e₂ = ((1 − g)·T − e₁)/Kv
///
/// (insert y = r − e into the loop and match the terms in ṙ and r̈). In lag mode (f = g = 0) at
/// constant speed this is document 004's e = q̇/Kv. `step()` integrates the loop exactly over one
/// interpolation period for the time-domain simulator.

#include <optional>

#include "postproc/machine/machine.hpp"

namespace postproc::contour {

struct Drive {
  double kv = 30;                     ///< position-loop gain, 1/s (> 0)
  double feed_forward = 0;            ///< velocity feed-forward fraction f, 0…1
  double acceleration_feed_forward = 0;  ///< acceleration feed-forward fraction g, 0…1
  double velocity_loop_time = 0;      ///< T, s (0: the velocity loop is ideal)

  /// Quasi-static following error for command velocity v (unit/s) and acceleration a (unit/s²).
  [[nodiscard]] double lag(double v, double a = 0) const {
    const double e1 = (1 - feed_forward) / kv;
    const double e2 = ((1 - acceleration_feed_forward) * velocity_loop_time - e1) / kv;
    return e1 * v + e2 * a;
  }
};

/// Following error e = r − y of a drive and its rate ė, for commands that move at a constant
/// velocity w between path points (the prediction of predict.hpp).
struct ErrorState {
  double e = 0;     ///< mm / degrees
  double rate = 0;  ///< de/dt, unit/s (used with a velocity loop, T > 0)
};

/// The command velocity changes by dw at a path point: e is continuous; with a velocity loop the
/// actual velocity is too (plus what the acceleration feed-forward impulse g·T·Δṙ adds), so ė
/// jumps by (1 − g)·dw.
void velocity_jump(const Drive& d, ErrorState& s, double dw);
/// Exact evolution over dt seconds of the error while the command moves at constant velocity w:
/// T·ë + ė + Kv·e = (1 − f)·w (T > 0), or ė + Kv·e = (1 − f)·w (T = 0). The steady state is
/// e = (1 − f)·w/Kv, document 004's q̇/Kv in lag mode.
void propagate(const Drive& d, ErrorState& s, double w, double dt);

/// The drive of a program axis from its machine-file settings; nullopt when the axis has no kv
/// (the machine file must give Kv for prediction; docs/machine-file.md [axes.X]).
[[nodiscard]] std::optional<Drive> drive_of(const machine::AxisSettings& s);

/// State of one simulated drive: actual position y (mm / deg) and actual velocity ẏ (unit/s).
struct DriveState {
  double y = 0;
  double v = 0;
};

/// Advances the closed loop by dt seconds with the command moving linearly from r0 to r1 over the
/// step (velocity ṙ = (r1 − r0)/dt, acceleration `a` for the feed-forward term). Exact for the
/// linear system over the step (matrix exponential of the 2×2 loop); with T = 0 the velocity
/// loop is ideal and the position loop a first-order lag, integrated exactly as well.
void step(const Drive& d, DriveState& s, double r0, double r1, double a, double dt);

}  // namespace postproc::contour
