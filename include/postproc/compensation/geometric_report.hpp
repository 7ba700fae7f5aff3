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
};

/// The page; throws Error(internal) without verify or points.
[[nodiscard]] std::string geometric_report_html(const GeometricReport& r);

}  // namespace postproc::comp
