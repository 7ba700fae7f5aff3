#pragma once
// Plotting for the self-contained HTML reports (contour, diff): inline SVG line plots, tool-path
// projections coloured by a value with their colour bar, histograms, a 3-D view (<canvas> and a
// small inline script, data embedded as JSON) and the page head. No network resources anywhere:
// the only URI written is the SVG namespace.
#include <cstddef>
#include <limits>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include <Eigen/Core>

namespace postproc::io {

/// Finite values seen; empty until one was added.
struct Range {
  double lo = std::numeric_limits<double>::infinity();
  double hi = -std::numeric_limits<double>::infinity();
  void add(double v);
  [[nodiscard]] bool empty() const { return !(lo <= hi); }
};

/// A step of 1, 2 or 5 × 10^k giving about `count` ticks over `span`.
[[nodiscard]] double nice_step(double span, int count);

/// Indices of at most `limit` of `values`: the first, the last, and between them the index of the
/// largest value (NaN counts as smallest) in each of `limit` − 2 consecutive buckets, ascending,
/// so that peaks survive. All indices when there are at most `limit` values or `limit` < 3.
[[nodiscard]] std::vector<std::size_t> decimate_max_indices(const std::vector<double>& values, std::size_t limit);

using Points2 = std::vector<std::pair<double, double>>;
/// decimate_max_indices over the y values of `in`.
[[nodiscard]] Points2 decimate_max(const Points2& in, std::size_t limit);

struct Series {
  std::string name;
  std::string colour;  ///< CSS colour
  Points2 xy;          ///< x ascending, finite
};

/// Line plot of y (the axis includes 0) against x, with a legend when there are several series.
/// `id` (optional) becomes the <svg>'s id. Labels carry their units, e.g. "deviation (µm)".
[[nodiscard]] std::string line_plot(const std::vector<Series>& series, std::string_view xlabel, std::string_view ylabel,
                                    std::string_view id = {});

/// Histogram of the finite `values` in `bins` equal bins from 0 (or the smallest value when it
/// is negative) to the largest; y is the count.
[[nodiscard]] std::string histogram(const std::vector<double>& values, int bins, std::string_view xlabel,
                                    std::string_view id = {});

/// Blue (0) → red (1); NaN as 1.
[[nodiscard]] std::string colour_of(double f);
inline constexpr int kColourLevels = 32;

/// A tool path to draw: points (mm, workpiece frame), one value each (e.g. µm; NaN = unknown,
/// drawn as 0), and the stretches [begin, end) drawn as connected lines (one-point stretches as
/// dots).
struct PlotPath {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> values;
  std::vector<std::pair<std::size_t, std::size_t>> runs;
};

/// The path in one projection (axes u, v ∈ {0: X, 1: Y, 2: Z}), 400 × 400 px, coloured by value
/// from 0 (blue) to `max_value` (red). At most `max_segments` segments: long paths take every
/// k-th point, a segment coloured by the largest value of the points it spans, large values drawn
/// last so that they stay visible where the path passes over itself.
[[nodiscard]] std::string projection(const PlotPath& path, int u, int v, double max_value, std::size_t max_segments,
                                     std::string_view id = {});

/// The colour scale of `projection`: 0 … max_value, with `label` (unit included) below.
[[nodiscard]] std::string colour_bar(double max_value, std::string_view label);

/// A 3-D view of the path: a <canvas> with id `id`, the decimated data (≤ `max_points` points, the
/// largest value of each bucket kept) as JSON in <script type="application/json" id="ID-data">,
/// and an inline script drawing it coloured as `projection`, drag to rotate, wheel to zoom.
[[nodiscard]] std::string view3d(const PlotPath& path, double max_value, std::size_t max_points, std::string_view id,
                                 std::string_view label);

/// `<!DOCTYPE html>` … `<body>`: charset, title, the reports' style sheet and `extra_css`.
[[nodiscard]] std::string page_head(std::string_view title, std::string_view extra_css = {});
/// Closes the page.
[[nodiscard]] std::string page_tail();

/// `v` formatted with `spec` (fmt syntax), or "–" when not finite.
[[nodiscard]] std::string cell(double v, const char* spec = "{:.3f}");

}  // namespace postproc::io
