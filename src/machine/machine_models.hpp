#pragma once
// Readers of the model sections of a machine file: each builds the nominal model (every error
// parameter 0); [errors] and [volumetric_map] are applied afterwards by parse_machine.
#include "postproc/kinematics/model.hpp"
#include "postproc/machine/machine.hpp"
#include "src/machine/toml_fields.hpp"

namespace postproc::machine {

/// [serial] with [[serial.workpiece_side]] / [[serial.tool_side]] axes and the optional
/// [error_motions.<axis>] tables.
kin::ModelPtr read_serial(TomlDoc& doc, Fields& f, const toml::table* error_motions, const Machine& m);
/// [prs_hybrid]: the 3-PRS head of document 001 on X/Y.
kin::ModelPtr read_prs_hybrid(TomlDoc& doc, Fields& f, const Machine& m);
/// [hexapod]: the 6×6 Stewart platform of document 003.
kin::ModelPtr read_hexapod(TomlDoc& doc, Fields& f, const Machine& m);

}  // namespace postproc::machine
