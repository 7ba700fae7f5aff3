#pragma once
/// @file
/// The figures of a compensation run as JSON, shared by `compensate --report` and the
/// `postproc batch` manifest: every key names its unit (…_mm, …_deg, …_um, …_arcsec).

#include <cstddef>
#include <string_view>

#include <nlohmann/json.hpp>

#include "postproc/compensation/compensate.hpp"
#include "postproc/gcode/diagnostic.hpp"

namespace postproc::comp {

/// `{"counts": {...}, "figures": {...}}` and, for the contour modes, `"contour": {...}` (with the
/// iteration history when `contour` is given).
[[nodiscard]] nlohmann::json result_json(const CompensateResult& r, Mode mode,
                                         const ContourDetails* contour = nullptr);

/// The stored diagnostics of `sink` (at most `limit`): severity, code, file, line, column, message.
[[nodiscard]] nlohmann::json diagnostics_json(const gcode::DiagnosticSink& sink, std::size_t limit = 1000);

}  // namespace postproc::comp
