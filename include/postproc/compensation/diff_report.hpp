#pragma once
/// @file
/// The self-contained HTML report of `postproc diff --html` (issue 7): what a correction did,
/// as a page that needs no network (inline SVG, one inline script for the 3-D view, no fonts).
///
/// Sections (element ids in brackets, for tests and links): the summary table [summary]; the
/// tool-tip path (diff.hpp BlockDiff::point_mm) in the XY, XZ and YZ projections
/// [projection-xy, projection-xz, projection-yz] and in a rotatable 3-D view [view3d], coloured by
/// the deviation (µm); the deviation along the path [along-path] (x: the path length through the
/// pairs' points in mm, or the pair index when a point is not known) and, with a machine, the
/// tool-axis angle [along-path-angle]; a histogram of the deviations [histogram]; the largest
/// deviations with both line numbers and both source lines [worst]; with predictions, the servo
/// contour errors of the original and of the corrected program against the original's intended
/// contour [contour]. Figures are rounded as `postproc diff` prints them (µm to 3 decimals,
/// arcsec to 2).

#include <cstddef>
#include <string>
#include <string_view>

#include "postproc/compensation/diff.hpp"
#include "postproc/contour/path.hpp"
#include "postproc/contour/predict.hpp"

namespace postproc::comp {

/// Points at most in the 3-D view (the largest deviation of each bucket kept).
inline constexpr std::size_t kDiffView3dMaxPoints = 20000;
/// Points at most per plotted series and segments per projection.
inline constexpr std::size_t kDiffPlotMaxPoints = 4000;

struct DiffReport {
  const DiffResult* result = nullptr;  ///< required
  std::string original_file;           ///< as given
  std::string corrected_file;
  std::string machine_file;            ///< empty without a machine
  std::string machine_sha256;
  std::string tool_version;
  std::string_view original_text;      ///< the programs (the caller keeps them alive), for source lines
  std::string_view corrected_text;
  std::size_t worst = 10;              ///< how many of the largest deviations to list
  /// Optional (`diff --predict`): the original's path, the predicted servo contour errors of the
  /// original program and of the corrected one, both against the original's intended contour
  /// (one PointPrediction per path point each).
  const contour::Path* path = nullptr;
  const contour::Prediction* predicted_before = nullptr;
  const contour::Prediction* predicted_after = nullptr;
};

/// The page. Throws postproc::Error (internal) when r.result is null.
[[nodiscard]] std::string diff_report_html(const DiffReport& r);

}  // namespace postproc::comp
