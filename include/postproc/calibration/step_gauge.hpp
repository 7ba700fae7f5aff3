#pragma once
/// @file
/// The 3-D step gauge of document 002: reading its measurement files, turning the sensor readings
/// into positioning errors, chaining several gauge placements and building a volumetric error map.
///
/// A gauge plate carries pyramids whose faces A, B, C have direction coefficients (ax, ay), …
/// (the face's slope along X and Y). A probe of three displacement sensors touching the faces reads
/// δ = T·E with T = [[ax, ay, 1], [bx, by, 1], [cx, cy, 1]], so E = T⁻¹δ at each pyramid, relative
/// to the gauge's reference pyramid (where the sensors were zeroed). Errors of gauges placed one
/// after the other add along a chain, E_OP = E_OO' + E_O'P; the plate's tilt, from line fits of two
/// edge scans, is removed linearly. File format and maths: docs/step-gauge.md.
///
/// Frames and units: positions and errors are in the machine frame (the frame of the linear axes,
/// as kin::VolumetricMap), mm; tilt angles rad. Files may use any length unit per column.

#include <cstdint>
#include <functional>
#include <optional>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include <Eigen/Core>

#include "postproc/calibration/csv.hpp"
#include "postproc/gcode/diagnostic.hpp"
#include "postproc/kinematics/volumetric_map.hpp"

namespace postproc::cal {

/// Where a datum was read: file, line and column, the line's text, the width to underline.
struct SourceRef {
  std::string file;
  gcode::SourceLocation where;
  std::string line;
  std::uint32_t length = 1;
};

/// One pyramid as read from a gauge file (one row).
struct Pyramid {
  std::string id;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< commanded position at the reading, machine frame, mm
  Eigen::Matrix3d t = Eigen::Matrix3d::Identity();     ///< T: rows [ax, ay, 1], [bx, by, 1], [cx, cy, 1]
  Eigen::Vector3d reading = Eigen::Vector3d::Zero();   ///< δ = (δA, δB, δC), mm
  SourceRef at;                                        ///< the row, underlining the pyramid id
};

/// "# chain: <pyramid> = <gauge>:<pyramid>": this gauge's pyramid sits where the other gauge's did,
/// so its absolute error is the other's (E_OO'), and the rest of this gauge follows (+ E_O'P).
struct ChainLink {
  std::string pyramid;        ///< of this gauge (usually its reference pyramid)
  std::string other_gauge;
  std::string other_pyramid;
  SourceRef at;               ///< the '# chain:' line
};

/// One gauge placement: a gauge file.
struct Gauge {
  std::string name;                ///< "# gauge:", unique over all files
  std::string reference;           ///< id of the pyramid where the sensors were zeroed
  std::vector<Pyramid> pyramids;   ///< in file order
  std::optional<ChainLink> chain;  ///< absent for the root gauge
  /// "# reference_error_<unit>: ex, ey, ez" (root gauge only): the reference pyramid's error
  /// relative to the machine zero, known from elsewhere, mm; 0 when absent.
  std::optional<Eigen::Vector3d> reference_error;
  SourceRef at;                    ///< the '# gauge:' line
};

/// The two reference-edge scans of one gauge placement (an edge file).
struct EdgeScan {
  std::string gauge;
  /// Per edge (0: the edge along X, giving θx; 1: along Y, giving θy): positions s along the edge
  /// (mm) and indicator readings (mm, positive when the edge surface is higher, +Z).
  std::vector<double> s[2];
  std::vector<double> reading[2];
  SourceRef at;                    ///< the '# gauge:' line of the edge file
};

/// Everything read from a set of step-gauge files.
struct StepGaugeData {
  std::vector<Gauge> gauges;
  std::vector<EdgeScan> edges;
};

/// Reads one parsed table into `data`: `# kind: step-gauge` (pyramid readings) or
/// `# kind: step-gauge-edge` (edge scans), see docs/step-gauge.md. `text` is the file's text, used
/// only to locate diagnostics about '#' header lines at their own line (without it they point at
/// the header line). Every problem is reported to table.sink() (codes PP-C001…PP-C006); returns
/// false when this file reported an error (nothing is added then).
bool add_step_gauge_file(CsvTable& table, StepGaugeData& data, std::string_view text = {});

/// Parses one file from memory and adds it (see add_step_gauge_file). False on any error.
bool add_step_gauge_text(std::string file, std::string_view text, StepGaugeData& data, gcode::DiagnosticSink& sink);

/// Reads and adds every file; nullopt when any reported an error. Throws postproc::Error
/// (no_input) when a file cannot be read.
[[nodiscard]] std::optional<StepGaugeData> read_step_gauge(std::span<const std::string> paths,
                                                           gcode::DiagnosticSink& sink);

/// Options of build_volumetric_map.
struct StepGaugeOptions {
  kin::VolumetricMap::Interpolation interpolation = kin::VolumetricMap::Interpolation::trilinear;
  kin::VolumetricMap::Outside outside = kin::VolumetricMap::Outside::refuse;
  double grid_tolerance_mm = 1e-3;  ///< how far a pyramid may lie from its grid node
  /// T is refused when σmin(T) < min_condition · σmax(T) (the reading noise would grow by 1/σmin).
  double min_condition = 1e-6;
};

/// What build_volumetric_map found, for printing.
struct StepGaugeReport {
  struct Point {
    std::string gauge;
    std::string pyramid;
    Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< machine frame, mm
    Eigen::Vector3d error = Eigen::Vector3d::Zero();     ///< E after tilt removal and chaining, mm
    double noise_gain = 0;  ///< 1/σmin(T): worst growth of reading noise into E (mm per mm)
  };
  struct Tilt {
    std::string gauge;
    bool measured = false;                              ///< false: no edge file, θ = 0
    Eigen::Vector2d theta = Eigen::Vector2d::Zero();    ///< θx, θy, rad
    Eigen::Vector2d rms = Eigen::Vector2d::Zero();      ///< line-fit residual per edge, mm
  };
  std::vector<Point> points;   ///< every pyramid, gauge by gauge in file order
  std::vector<Tilt> tilts;     ///< per gauge
  double max_error = 0;        ///< max |E| over the points, mm
};

/// E = T⁻¹δ per pyramid, relative to the gauge's reference pyramid, tilt removed, chained into
/// one field; the union of the pyramid positions must be a regular grid (≥ 2 nodes per axis, every
/// node exactly once within grid_tolerance_mm; pyramids joined by a chain count once). Every
/// refusal is a located diagnostic (PP-C005 singular T, PP-C006 inconsistent chain or grid).
[[nodiscard]] std::optional<kin::VolumetricMap> build_volumetric_map(const StepGaugeData& data,
                                                                     const StepGaugeOptions& options,
                                                                     gcode::DiagnosticSink& sink,
                                                                     StepGaugeReport* report = nullptr);

/// A complete `[volumetric_map]` TOML section (docs/machine-file.md; unit "um", 4 decimals) that
/// machine::parse_machine reads back.
[[nodiscard]] std::string volumetric_map_toml(const kin::VolumetricMap& map);

// ---------------------------------------------------------------------------------------------
// Simulation: the readings a gauge would give on a machine with a known error field.

/// One pyramid of a simulated gauge.
struct PyramidLayout {
  std::string id;
  Eigen::Vector3d position = Eigen::Vector3d::Zero();  ///< machine frame, mm
  /// Rows A, B, C: (ax, ay) direction coefficients of the faces.
  Eigen::Matrix<double, 3, 2> faces = Eigen::Matrix<double, 3, 2>::Zero();
};

/// One simulated gauge placement.
struct GaugeLayout {
  std::string name;
  std::vector<PyramidLayout> pyramids;
  std::string reference;                   ///< id of the reference pyramid
  std::optional<std::string> chain;        ///< written verbatim after "# chain: ", e.g. "1 = low:12"
  bool write_reference_error = false;      ///< root gauge: write the field at the reference pyramid
  Eigen::Vector2d tilt = Eigen::Vector2d::Zero();  ///< θx, θy of the plate, rad
  bool edges = true;                       ///< also write the edge file
  int edge_points = 11;                    ///< readings per edge
};

/// A plate with nx × ny pyramids at `origin` + (i·spacing.x, j·spacing.y, 0), ids 1… (x fastest),
/// reference pyramid 1, face slopes tan 40° at azimuths 90°, 210°, 330° turned by a few degrees per
/// pyramid (as calibrated pyramids differ), pseudo-random from `seed`.
[[nodiscard]] GaugeLayout plate_layout(std::string name, const Eigen::Vector3d& origin, const Eigen::Vector2d& spacing,
                                       int nx, int ny, std::uint64_t seed = 1);

/// The gauges that cover a map's grid: one plate per z level ("plate1"…, counts.x × counts.y
/// pyramids on the grid nodes, the plate tilts given per level, repeated cyclically; none: level),
/// and a vertical "column" gauge with one pyramid per level at the grid's (0, 0) node that chains
/// the plates (plate k's pyramid 1 = column:k). plate1 is the root and carries the field at its
/// reference pyramid (write_reference_error), so the map comes out absolute.
[[nodiscard]] std::vector<GaugeLayout> grid_layouts(const Eigen::Vector3d& origin, const Eigen::Vector3d& spacing,
                                                    const Eigen::Vector3i& counts,
                                                    std::span<const Eigen::Vector2d> tilts = {}, std::uint64_t seed = 1);

struct StepGaugeSimulateOptions {
  double noise_mm = 0;         ///< uniform noise ±noise_mm on every sensor and edge reading
  std::uint64_t seed = 1;
  int decimals = -1;           ///< decimals written (in the file's units); -1: shortest exact
  std::string comment;         ///< extra '#' line(s) at the top, e.g. how the file was made
};

/// The CSV texts of one simulated gauge placement (edge empty when layout.edges is false).
struct SimulatedGauge {
  std::string gauge_csv;
  std::string edge_csv;
};

/// The files a gauge would give on a machine whose positioning error is `field` (mm at a machine
/// position, mm): δ = T·(E(P) − E(P_ref) − ω×(P − P_ref)) + noise, with ω the plate tilt, and edge
/// readings θ·s + noise. Throws postproc::Error (usage) when a layout's reference is not one of
/// its pyramids.
[[nodiscard]] std::vector<SimulatedGauge> simulate_step_gauge(
    const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& field, std::span<const GaugeLayout> layouts,
    const StepGaugeSimulateOptions& options);

}  // namespace postproc::cal
