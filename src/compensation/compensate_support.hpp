#pragma once
// compensate: the models per tool length, and the writer of corrected axis / tool-vector words.
#include <cmath>
#include <cstdint>
#include <map>
#include <optional>
#include <span>
#include <string>
#include <utility>

#include "postproc/compensation/compensate.hpp"
#include "postproc/contour/simulate.hpp"
#include "postproc/machine/program_map.hpp"
#include "postproc/gcode/block_writer.hpp"
#include "postproc/gcode/program.hpp"
#include "postproc/gcode/write_back.hpp"
#include "postproc/machine/machine.hpp"
#include "src/gcode/convert_support.hpp"

namespace postproc::comp {

using gcode::header_waits;  // gcode/write_back.hpp
// The controller's map per program form (machine/program_map.hpp).
using machine::Command;
using machine::Form;
using machine::map_of;
using machine::ModalToolVector;
using machine::ProgramMap;
using machine::ToolLengthModels;
using machine::written_axes;

// Issue 17, compensation verification gate (docs/compensation-verification.md): codes PP-E620…E629,
// PP-W620…W629.
inline constexpr std::string_view kContourWithheld = "PP-W620";    // a run's contour correction simulated not better
inline constexpr std::string_view kContourUnverified = "PP-W621";  // the written program could not be simulated
// PP-E620 (compensate.cpp): the program already carries postproc's compensation header.
// PP-E621 (kToolLengthError below): [errors] "tool.length" and a block with another tool length.

/// mm (or degrees) per program unit of axis `a` in motion `m` (inch programs, X as a diameter).
[[nodiscard]] double unit_scale(int a, const gcode::Motion& m);
/// A value in mm / degrees as the program writes it (inch, diameter).
[[nodiscard]] double program_units(int a, double v, const gcode::Motion& m);
/// Decimals written for axis `a` in motion `m`'s units: [axes] decimals counts in mm (3: 1 µm); an
/// inch program's linear words carry one more (0.0001 in = 2.54 µm, the controllers' inch
/// increment), else the corrections of inch programs would be rounded to 25.4 µm.
[[nodiscard]] int program_decimals(const machine::Machine& mc, int a, const gcode::Motion& m);
/// What goes before a word inserted into block b: a blank when the block has blanks, or a
/// Sinumerik `X=…` word (which needs one after it: `C=ACP(10) X5`, not `C=ACP(10)X5`); nothing in
/// a block written without blanks (`X10Y5`).
[[nodiscard]] std::string word_separator(const gcode::Block& b);
using machine::kToolLengthError;  // PP-E621

/// The first motion of a block that runs under cutter radius compensation with a radius above 0 or
/// not known (gcode::Motion::cutter_radius), nullptr when none does.
[[nodiscard]] const gcode::Motion* cutter_offset_motion(std::span<const gcode::Motion> motions);
/// Why such a program is refused: the controller would offset corrected points again.
[[nodiscard]] std::string cutter_offset_refusal(const gcode::Motion& m);
/// Why a corrected block is refused whose line the controller could not read (`why`:
/// gcode::line_too_long's reason).
[[nodiscard]] std::string corrected_line_too_long(std::string_view why);

/// The rounding bound of a written motion: half a unit of the last decimal of each written axis
/// (`need`), carried through the controller's map to the tool tip (sum over the axes of the
/// largest tip distance, mm) and the tool axis (rad); tool vectors add their 6-decimal components
/// (200 mm lever). `got`: the real pose of the motion as written, `start` its branch.
struct RoundingBound {
  double tip_mm = 0;
  double axis_rad = 0;
};
[[nodiscard]] RoundingBound rounding_bound(const machine::Machine& m, const ProgramMap& map, const gcode::Motion& mc,
                                           gcode::AxisMask need, machine::Form f, const kin::JointVector& start,
                                           const kin::Pose& got);

/// One block's single motion as read back (tool vector carried modally).
struct CollectedMotion {
  gcode::Motion motion;
  bool reference = false;  ///< a G28/G30 block
};

/// The single motion of every line of a program (blocks with several motions are skipped).
class MotionCollector final : public gcode::BlockVisitor {
 public:
  explicit MotionCollector(const gcode::Dialect& d) : track_(d) {}
  void block(const gcode::Block& b, std::span<const gcode::Motion> motions, bool) override;
  std::map<std::uint64_t, CollectedMotion> by_line;

 private:
  gcode::ModalTrack track_;
  Eigen::Vector3d vector_ = Eigen::Vector3d::UnitZ();
  bool known_ = false;
};

/// Writes corrected values into a block's words, in each word's own style, at no fewer decimals
/// than the machine's output decimals for the axis.
class WordWriter {
 public:
  WordWriter(const gcode::Dialect& d, const machine::Machine& m, const gcode::ModalTrack& track)
      : d_(d), m_(m), track_(track) {}

  struct Outcome {
    bool ok = true;
    std::uint32_t column = 1;  ///< refusal: the word's column
    std::string why;
    std::uint32_t changed = 0;
    std::uint32_t inserted = 0;
  };
  /// Rewrites the block's words for `mask` (and the tool vector for vector forms) so that the
  /// block ends at `target`. `start`: the corrected position the controller holds before the
  /// block (valid where `start_known`), for incremental words and absent axes. `g93_scale` > 0:
  /// inverse-time F multiplied by it (the block is the first piece of a split move and takes
  /// 1 / g93_scale of the move's time: the piece count for equal pieces).
  Outcome rewrite(const gcode::Block& b, const gcode::Motion& m, gcode::AxisMask mask, const gcode::AxisVector& start,
                  gcode::AxisMask start_known, const Command& target, gcode::BlockEditor& ed,
                  double g93_scale = 0);
  /// A new line continuing the block's motion from `from` to `to` (`g93_scale` > 0: its inverse-time
  /// F is the block's multiplied by it, the piece taking that share of the move's time); nullopt when
  /// a rotary word cannot be written under its axis's roll-over rule.
  std::optional<std::string> segment_line(const gcode::Block& b, const gcode::Motion& m, gcode::AxisMask mask,
                                          const gcode::AxisVector& from, const Command& to,
                                          double g93_scale);

 private:
  /// The style of inserted words and new lines: plain, leading zero, trimmed trailing zeros.
  [[nodiscard]] static gcode::NumberStyle default_style() { return gcode::NumberStyle{false, true, 3, false, false}; }
  /// The style of inserted words: Klartext writes a sign on every coordinate (X+10).
  [[nodiscard]] gcode::NumberStyle insert_style() const {
    gcode::NumberStyle s = default_style();
    s.plus_sign = d_.id == gcode::DialectId::heidenhain;
    return s;
  }
  /// Tool-vector word names: Fanuc I J K, Sinumerik A3= B3= C3=, Klartext TX TY TZ.
  [[nodiscard]] std::string vector_name(int k) const {
    if (d_.id == gcode::DialectId::siemens) return std::string(1, "ABC"[k]) + "3=";
    if (d_.id == gcode::DialectId::heidenhain) return std::string("T") + "XYZ"[k];
    return std::string(1, "IJK"[k]);
  }
  /// `number` with the block's decimal separator: ',' where the block writes its numbers with one.
  [[nodiscard]] static std::string decimal_mark(const gcode::Block& b, std::string number) {
    for (const gcode::Word& w : b.words)
      if (b.text(w.value).find(',') != std::string_view::npos) {
        for (char& c : number)
          if (c == '.') c = ',';
        break;
      }
    return number;
  }
  [[nodiscard]] bool vector_form(const gcode::Motion& m) const;
  /// The value of an absolute word of axis `a` that moves it from `from` to `target` (program
  /// units): `target`, or under a rotary roll-over rule the word nearest `like` that gets there;
  /// nullopt when none does.
  [[nodiscard]] std::optional<double> absolute_word(int a, double target, double from, double like) const;
  /// The refusal of a rotary word no roll-over word can express (PP-E6xx message text).
  [[nodiscard]] std::string rollover_refusal(int a, double target, double from) const;
  const gcode::Dialect& d_;
  const machine::Machine& m_;
  const gcode::ModalTrack& track_;
};

/// The contour stage's written text read back through the reader and simulated against the
/// reference of `d` (the path of the contour stage's input, or of another candidate with the same
/// runs); nullopt (with `why`) when it cannot be (diagnostics, other runs, throw). With
/// `so.visit` the written program must also have the path points of `d`.
std::optional<contour::Simulation> simulate_written(const std::string& written, std::string_view file,
                                                    const gcode::Dialect& dialect, const machine::Machine& m,
                                                    const ContourDetails& d, std::string& why,
                                                    const contour::SimulateOptions& so = {});

}  // namespace postproc::comp
