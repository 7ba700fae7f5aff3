#pragma once
/// @file
/// Reports of `postproc predict`, `postproc simulate` and `compensate --mode contour`: per-point CSV,
/// JSON (summary, worst places with their source lines, iterations) and a self-contained HTML page
/// (inline SVG, no network resources). Every number carries its unit in its name or heading:
/// tool-tip errors in µm, tool-axis errors in arcsec… as the column names say.

#include <cstddef>
#include <string>
#include <vector>

#include "postproc/contour/path.hpp"
#include "postproc/contour/precompensate.hpp"
#include "postproc/contour/simulate.hpp"

namespace postproc::contour {

struct ContourReport {
  std::string title;             ///< e.g. "predict cone_frustum_nas979.nc"
  std::string program;           ///< input file as given
  std::string machine_file;
  std::string machine_sha256;
  std::string tool_version;
  const Path* path = nullptr;                    ///< required
  const Prediction* before = nullptr;            ///< required: predicted errors of the program
  const Prediction* after = nullptr;             ///< optional: after precompensation
  const Precompensation* compensation = nullptr; ///< optional: iterations, history
  const Simulation* simulated_before = nullptr;  ///< optional: time-domain results
  const Simulation* simulated_after = nullptr;   ///< optional
  double fit_residual_mm = 0;                    ///< largest NURBS fit residual of the reference
  std::string appendix;                          ///< HTML appended to the page (e.g. compensate --mode all's geometric part)
  std::size_t worst = 10;                        ///< how many worst places to list
};

/// One row per path point: index, line, time_s, run, tool tip x/y/z (mm, intended), following
/// error per joint (mm or deg, the joint's name in the heading), tip contour error (µm) and its
/// vector (µm), tool-axis contour error (arcsec); with `after`, the same errors after correction.
/// Columns: `index,line,time_s,run,x_mm,y_mm,z_mm,following_<joint>_<mm|deg>…,tip_um,tip_x_um,
/// tip_y_um,tip_z_um,axis_arcsec` and, with `after`, the error columns again prefixed `after_`.
/// The intended tip is the foot point (PointPrediction::tip + error). Joint names and units come
/// from path->maps[0]'s actual model; a path without maps names its joints j1, j2… (unit mm).
[[nodiscard]] std::string report_csv(const ContourReport& r);
/// Summary (max / RMS / p95, µm and arcsec), the worst places (point, line, error), the
/// iterations and the simulated figures when present. `reduction_percent` is
/// 100·(1 − after.max / before.max), null when before.max is 0; `worst` / `worst_axis` list the
/// r.worst largest tool-tip / tool-axis errors of `before`, largest first (ties: earlier point first).
[[nodiscard]] std::string report_json(const ContourReport& r);
/// A self-contained page: summary table, contour error along the path (before / after), the
/// tool-tip path in the XY, XZ and YZ projections coloured by error, and the worst places.
/// Long paths are decimated for plotting (≤ 4000 points per series, the largest error of each
/// bucket kept) so the page stays small; no scripts, no external resources.
/// All three throw postproc::Error (internal) when r.path or r.before is null.
[[nodiscard]] std::string report_html(const ContourReport& r);

}  // namespace postproc::contour
