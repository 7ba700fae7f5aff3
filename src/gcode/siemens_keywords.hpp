#pragma once
// Siemens names shared by the interpreter and the resolver's pre-scan.
#include <string_view>

namespace postproc::gcode {

/// A Sinumerik keyword the interpreter accepts as a modal state change (CFC, SOFT, ORIWKS, …),
/// case-insensitive.
[[nodiscard]] bool siemens_state_keyword(std::string_view name);

/// A Sinumerik predefined procedure, function or cycle name (MSG, TRAORI, CYCLE800, …; upper
/// case): not a call of a subprogram of the user's.
[[nodiscard]] bool siemens_builtin_name(std::string_view upper_name);

}  // namespace postproc::gcode
