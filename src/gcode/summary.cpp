#include "postproc/gcode/summary.hpp"

namespace postproc::gcode {

void ProgramSummary::add(const Motion& m) {
  ++motions_by_type[static_cast<std::size_t>(m.type)];
  axes_used |= m.programmed;
  if (m.frame == Frame::machine) {
    ++machine_frame_moves;
  } else {
    for (int a = 0; a < kAxisCount; ++a)
      if ((m.known >> a) & 1u) {
        min[a] = std::min(min[a], m.end[a]);
        max[a] = std::max(max[a], m.end[a]);
      }
  }
  if (m.type != MotionType::rapid && m.feed_known) {
    auto& f = feeds[static_cast<std::size_t>(m.feed_mode)];
    f.min = std::min(f.min, m.feed);
    f.max = std::max(f.max, m.feed);
    ++f.count;
  }
}

std::uint64_t ProgramSummary::motions() const {
  std::uint64_t n = 0;
  for (auto c : motions_by_type) n += c;
  return n;
}

}  // namespace postproc::gcode
