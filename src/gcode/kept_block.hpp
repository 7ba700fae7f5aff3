#pragma once
// A block kept past its line: its text is owned, its spans index into it.
#include <string>

#include "postproc/gcode/block.hpp"

namespace postproc::gcode {

/// A block kept for later (a cycle's shape, the block whose move is held): its text is owned, its
/// spans index into it.
struct KeptBlock {
  std::string raw;
  Block block;
  void keep(const Block& b) {
    raw.assign(b.raw);
    block = b;
    block.raw = raw;
    block.eol = {};
  }
  [[nodiscard]] const Block& get() {
    block.raw = raw;  // after a copy or a move of the vector that holds it
    return block;
  }
};

}  // namespace postproc::gcode
