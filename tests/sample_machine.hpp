#pragma once
// The sample machine files in unit tests (POSTPROC_SOURCE_DIR is set by tests/CMakeLists.txt).
#include <gtest/gtest.h>

#include <stdexcept>
#include <string>

#include "postproc/gcode/diagnostic.hpp"
#include "postproc/machine/machine.hpp"

namespace pptest {

/// samples/machines/<name>, loaded; every diagnostic is a test failure, a refused file throws.
inline postproc::machine::Machine sample_machine(const std::string& name) {
  postproc::gcode::DiagnosticSink sink;
  auto m = postproc::machine::load_machine(std::string(POSTPROC_SOURCE_DIR) + "/samples/machines/" + name, sink);
  for (const auto& d : sink.stored()) ADD_FAILURE() << postproc::gcode::format(d);
  if (!m) throw std::runtime_error("machine file refused: " + name);
  return *m;
}

}  // namespace pptest
