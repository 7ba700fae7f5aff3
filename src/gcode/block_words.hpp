#pragma once
// What one block says, gathered once by letter so the interpreter's steps can look words up.
#include <array>
#include <cstdint>

#include "postproc/gcode/interpreter.hpp"

namespace postproc::gcode {

/// Centre-offset letters for each plane axis (I J K belong to X Y Z).
constexpr char centre_letter(int axis) { return static_cast<char>('I' + axis); }

struct Interpreter::BlockWords {
  struct G {
    const GCodeDef* def = nullptr;
    std::int16_t word = -1;
  };
  std::array<G, 12> g;  ///< first ng entries valid
  int ng = 0;
  G motion;  ///< the motion-group G code of this block, if any

  AxisVector axis;                        ///< values as written (program units); valid where present
  AxisMask axis_present = 0;
  AxisMask axis_incremental = 0;          ///< U/W/H on Fanuc lathes, Siemens IC()
  AxisMask axis_absolute = 0;             ///< Siemens AC() (and DC() ACP() ACN())
  /// Siemens DC() / ACP() / ACN() per axis (RotaryDirection of rotary_direction.hpp; 0: none).
  std::array<std::uint8_t, kAxisCount> axis_direction{};
  AxisMask axis_unresolved = 0;           ///< written with an expression or parameter
  std::array<std::int8_t, kAxisCount> axis_word{};

  std::array<double, 26> letter;          ///< valid where letter_present; other single-letter words (I J K R P Q L F S T H D E …)
  std::uint32_t letter_present = 0;
  std::uint32_t letter_unresolved = 0;
  std::array<std::int16_t, 26> letter_word{};
  std::uint32_t letter_absolute = 0;      ///< Siemens I=AC(…) absolute centre

  double cr = 0;                          ///< Siemens CR= radius
  bool has_cr = false;
  // Sinumerik motion addresses (840D sl Fundamentals, "Motion commands").
  double ar = 0;                          ///< AR= opening angle, degrees
  bool has_ar = false;
  double turn = 0;                        ///< TURN= additional full turns of a helix
  bool has_turn = false;
  Eigen::Vector3d ip = Eigen::Vector3d::Zero();  ///< CIP intermediate point I1= J1= K1= (program values)
  std::uint8_t ip_present = 0, ip_absolute = 0, ip_incremental = 0;  ///< bits 0..2 = I1 J1 K1
  std::uint8_t ext_unresolved = 0;        ///< bits: 1 CR, 2 AR, 4 TURN, 8 I1/J1/K1, 16 AP, 32 RP not literal
  std::int16_t cr_word = -1, ar_word = -1, turn_word = -1, ip_word = -1;
  std::int16_t siemens_corner_word = -1;          ///< CHF= CHR= RND= RNDM= (first of them)
  double ap = 0, rp = 0;                  ///< AP= polar angle (deg), RP= polar radius (program units)
  bool has_ap = false, has_rp = false, ap_incremental = false, rp_incremental = false;
  int m_count = 0;
  std::array<double, 8> m;               ///< first m_count entries valid
  std::array<std::int16_t, 8> m_word;

  Eigen::Vector3d vector = Eigen::Vector3d::Zero();  ///< Siemens A3/B3/C3 components (program values)
  std::uint8_t vector_present = 0;        ///< bits 0..2 = A3 B3 C3 given literally
  bool polar = false;                     ///< Siemens AP=/RP= polar coordinates in this block
  double polar_distance = 0, polar_angle = 0;  ///< LinuxCNC @ (program units) and ^ (degrees)
  std::uint8_t polar_words = 0;           ///< bit 0 = @, bit 1 = ^ given; bit 2 = one is unresolved
  std::int16_t polar_word = -1;           ///< index of the first of them
  bool siemens_motion_keyword = false;    ///< CIP, CT, BSPLINE, … in this block
  Span motion_keyword_span;               ///< where CIP / CT is written
  bool machine_frame = false;             ///< G53 / SUPA / G153 in this block
  std::int16_t corner_word = -1;          ///< Fanuc ,C / ,R / ,A word of this block
  bool words_transformed = false;         ///< Fanuc G16/G51.1: axis values were converted to the work frame
  bool axes_consumed = false;             ///< axis words were data for G10/G52/G92/… (no motion)

  /// True when the block gives axis `a` as an absolute literal (not G91, IC() or lathe U/W, not
  /// an expression), so that its position after the block is stated whatever came before.
  [[nodiscard]] bool states_absolutely(Axis a, bool absolute_mode) const {
    const AxisMask ab = bit(a);
    return (axis_present & ab) && !(axis_unresolved & ab) && !(axis_incremental & ab) &&
           (absolute_mode || (axis_absolute & ab));
  }
  [[nodiscard]] bool has(char L) const { return (letter_present >> (L - 'A')) & 1u; }
  [[nodiscard]] double get(char L) const { return letter[static_cast<std::size_t>(L - 'A')]; }
  [[nodiscard]] bool unresolved(char L) const { return (letter_unresolved >> (L - 'A')) & 1u; }
  /// The value of letter L as a whole number in [lo, hi], or `fallback` when absent, unresolved or
  /// not a whole number in range (callers that must refuse check `whole()` first).
  [[nodiscard]] long whole_or(char L, long lo, long hi, long fallback) const {
    if (!has(L) || unresolved(L)) return fallback;
    const double v = get(L);
    if (!(v >= static_cast<double>(lo) && v <= static_cast<double>(hi)) || v != static_cast<double>(static_cast<long>(v)))
      return fallback;
    return static_cast<long>(v);
  }
  [[nodiscard]] bool has_meaning(GMeaning meaning) const {
    for (int i = 0; i < ng; ++i)
      if (g[static_cast<std::size_t>(i)].def->meaning == meaning) return true;
    return false;
  }
  [[nodiscard]] const G* find(GMeaning meaning) const {
    for (int i = 0; i < ng; ++i)
      if (g[static_cast<std::size_t>(i)].def->meaning == meaning) return &g[static_cast<std::size_t>(i)];
    return nullptr;
  }
  [[nodiscard]] bool has_m(double code) const {
    for (int i = 0; i < m_count; ++i)
      if (m[static_cast<std::size_t>(i)] == code) return true;
    return false;
  }
};

}  // namespace postproc::gcode
