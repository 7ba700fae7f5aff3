#pragma once
/// @file
/// The inputs of this run, so that no output is ever written over one (issue 21): every input
/// read through io::read_file, gcode::LineReader or a tool table is noted by its file identity
/// (device and inode, through symbolic and hard links) while a run is under way (RunInputs);
/// OutputFile refuses a target that is one of them (PP-E901, exit 64).

#include <string>
#include <string_view>

namespace postproc::io {

/// One run (a command, a batch): while one exists, the inputs read are noted; when the last one
/// ends they are forgotten, so a later run may write where an earlier one read. Thread-safe; the
/// workers of a batch share their run's scope.
class RunInputs {
 public:
  RunInputs();
  ~RunInputs();
  RunInputs(const RunInputs&) = delete;
  RunInputs& operator=(const RunInputs&) = delete;
};

/// Within a run (RunInputs), notes `path` (not "-") as an input of this run; `what` names it in messages ("machine file").
/// A path that does not exist is ignored. Thread-safe.
void note_input(const std::string& path, std::string_view what);

/// The noted input that `path` designates (the same file, through links), as "WHAT PATH"; empty
/// when `path` is none of them or does not exist. An input whose path now names another file (it was
/// replaced since) no longer counts.
[[nodiscard]] std::string input_at(const std::string& path);

}  // namespace postproc::io
