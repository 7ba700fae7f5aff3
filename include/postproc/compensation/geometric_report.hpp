#pragma once
/// @file
/// The self-contained HTML report of `compensate --mode geometric --html`: the error the original
/// program leaves on the calibrated machine beside the residual of the corrected program, both
/// from verify() (the written program read back and run through the actual model), per end point:
/// along the path, as histograms, on the tool-tip path, and the worst places.

#include <string>
#include <vector>

#include "postproc/compensation/verify.hpp"

namespace postproc::comp {

struct GeometricReport {
  std::string title;           ///< page title (default "postproc compensate report")
  std::string program;         ///< input program file
  std::string output;          ///< written program file
  std::string machine_file;
  std::string machine_sha256;
  std::string tool_version;
  const VerifyResult* verify = nullptr;             ///< required
  const std::vector<VerifyPoint>* points = nullptr; ///< required: verify()'s compared end points
  std::string id_prefix;       ///< prefixed to every element id (a section inside another page)
};

/// The page; throws Error(internal) without verify or points.
[[nodiscard]] std::string geometric_report_html(const GeometricReport& r);
/// The same content without the page's head and tail, headed by an <h1> of `r.title`, to go into
/// another page (compensate --mode all: the contour report's appendix).
[[nodiscard]] std::string geometric_report_section(const GeometricReport& r);

}  // namespace postproc::comp
