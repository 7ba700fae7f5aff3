// JSON of a compensation run's figures (compensate --report, the batch manifest).
#include "postproc/compensation/result_json.hpp"

#include <string>

namespace postproc::comp {
namespace {
constexpr double kDeg = 180.0 / 3.14159265358979323846;
constexpr double kArcsec = kDeg * 3600.0;
}  // namespace

nlohmann::json result_json(const CompensateResult& r, Mode mode, const ContourDetails* contour) {
  nlohmann::json j;
  j["counts"] = {{"blocks", r.blocks},
                 {"motions", r.motions},
                 {"changed_blocks", r.changed_blocks},
                 {"words_changed", r.words_changed},
                 {"words_inserted", r.words_inserted},
                 {"subdivided_blocks", r.subdivided_blocks},
                 {"segments_added", r.segments_added},
                 {"arcs_kept", r.arcs_kept},
                 {"arcs_linearized", r.arcs_linearized},
                 {"reference_moves", r.reference_moves},
                 {"rapids_as_written", r.rapids_as_written},
                 {"axis_limited_blocks", r.axis_limited_blocks}};
  j["figures"] = {{"max_correction_mm", r.max_correction_mm},
                  {"max_correction_deg", r.max_correction_deg},
                  {"max_axis_correction_rad", r.max_axis_correction_rad},
                  {"max_error_before_mm", r.max_error_before_mm},
                  {"max_error_before_deg", r.max_error_before_rad * kDeg},
                  {"worst_line_before", r.worst_line},
                  {"max_residual_after_mm", r.max_residual_mm},
                  {"max_residual_after_deg", r.max_residual_rad * kDeg}};
  if (r.axis_limited_blocks > 0) {
    // Where the tool axis was corrected only in part (near a singular pose): per block, line and
    // the tool-axis error before and after, so a user sees where the part keeps an axis error.
    nlohmann::json list = nlohmann::json::array();
    for (const AxisLimitedBlock& a : r.axis_limited)
      list.push_back({{"line", a.line}, {"before_arcsec", a.before_rad * kArcsec}, {"after_arcsec", a.after_rad * kArcsec}});
    j["tool_axis_limited"] = {{"blocks", r.axis_limited_blocks},
                              {"max_after_arcsec", r.axis_limited_max_rad * kArcsec},
                              {"listed", list},
                              {"truncated", r.axis_limited_blocks > r.axis_limited.size()}};
  }
  if (r.parallel_chunks > 0)  // the geometric stage on several threads (CompensateOptions::jobs)
    j["parallel"] = {{"chunks", r.parallel_chunks}, {"recomputed", r.parallel_recomputed}};
  if (r.resolved_lines > 0) {  // a program with parameters or control flow (gcode/resolve.hpp)
    nlohmann::json used = nlohmann::json::object();
    for (const auto& [name, value] : r.used_settings) used[name] = value;
    j["resolution"] = {{"resolved_lines", r.resolved_lines},
                       {"written", r.flattened ? "flattened" : "in place"},
                       {"source_lines_rewritten", r.source_lines_rewritten},
                       {"set_used", used}};
  }
  if (mode != Mode::geometric) {
    j["contour"] = {{"before_tip_um", r.contour_before_mm * 1000},
                    {"before_axis_arcsec", r.contour_before_rad * kArcsec},
                    {"after_tip_um", r.contour_after_mm * 1000},
                    {"after_axis_arcsec", r.contour_after_rad * kArcsec},
                    {"predicted_after_tip_um", r.contour_predicted_after_mm * 1000},
                    {"predicted_after_axis_arcsec", r.contour_predicted_after_rad * kArcsec},
                    {"simulated", r.contour_verified},
                    {"runs", r.contour_runs},
                    {"runs_withheld", r.contour_runs_withheld},
                    {"worst_line_before", r.contour_worst_line},
                    {"iterations", r.contour_iterations},
                    {"converged", r.contour_converged},
                    {"fit_residual_um", r.fit_residual_mm * 1000}};
    j["contour"]["runs_iterated"] = r.contour_runs_iterated;
    j["contour"]["runs_lag"] = r.contour_runs_lag;
    j["contour"]["runs_refined"] = r.contour_runs_refined;
    // The split candidate (compensate --contour-split auto), both simulated against the original's contour.
    j["contour"]["split"] = {{"tried", r.contour_split_tried},
                             {"written", r.contour_split_written},
                             {"runs_split", r.contour_split_runs},
                             {"moves_split", r.moves_split},
                             {"arcs_as_chords", r.contour_split_arcs},
                             {"split_after_tip_um", r.contour_split_after_mm * 1000},
                             {"split_after_axis_arcsec", r.contour_split_after_rad * kArcsec},
                             {"unsplit_after_tip_um", r.contour_unsplit_after_mm * 1000},
                             {"unsplit_after_axis_arcsec", r.contour_unsplit_after_rad * kArcsec}};
    j["contour"]["runs_uncorrected"] =
        r.contour_runs - std::min(r.contour_runs, r.contour_runs_iterated + r.contour_runs_lag + r.contour_runs_refined);
    j["contour"]["stops"] = {{"converged", r.contour_runs_stopped[1]},
                             {"no_improvement", r.contour_runs_stopped[2]},
                             {"iteration_limit", r.contour_runs_stopped[3]},
                             {"nothing_to_correct", r.contour_runs_stopped[0]}};
    nlohmann::json per_run = nlohmann::json::array();
    for (const ContourRunReport& c : r.contour_run_reports)
      per_run.push_back({{"line", c.line},
                         {"moves", c.moves},
                         {"iterations", c.iterations},
                         {"stop", c.stop},
                         {"written", c.written},
                         {"predicted_before_tip_um", c.predicted_before_mm * 1000},
                         {"predicted_after_tip_um", c.predicted_after_mm * 1000},
                         {"before_tip_um", c.before_mm * 1000},
                         {"before_axis_arcsec", c.before_rad * kArcsec},
                         {"before_tip_rms_um", c.before_rms_mm * 1000},
                         {"iterated_tip_um", c.iterated_mm * 1000},
                         {"iterated_axis_arcsec", c.iterated_rad * kArcsec},
                         {"iterated_tip_rms_um", c.iterated_rms_mm * 1000},
                         {"lag_tip_um", c.lag_mm * 1000},
                         {"lag_axis_arcsec", c.lag_rad * kArcsec},
                         {"lag_tip_rms_um", c.lag_rms_mm * 1000},
                         {"refined_steps", c.refined_steps},
                         {"refined_tip_um", c.refined_mm * 1000},
                         {"refined_axis_arcsec", c.refined_rad * kArcsec},
                         {"refined_tip_rms_um", c.refined_rms_mm * 1000}});
    j["contour"]["run_details"] = per_run;
    if (contour != nullptr) {
      nlohmann::json hu = nlohmann::json::array(), ha = nlohmann::json::array();
      for (double v : contour->result.history_mm) hu.push_back(v * 1000);
      for (double v : contour->result.history_rad) ha.push_back(v * kArcsec);
      j["contour"]["history_tip_um"] = hu;
      j["contour"]["history_axis_arcsec"] = ha;
    }
  }
  return j;
}

nlohmann::json diagnostics_json(const gcode::DiagnosticSink& sink, std::size_t limit) {
  nlohmann::json diags = nlohmann::json::array();
  for (const auto& d : sink.stored()) {
    if (diags.size() >= limit) break;
    diags.push_back({{"severity", std::string(gcode::to_string(d.severity))},
                     {"code", d.code},
                     {"file", d.file},
                     {"line", d.where.line},
                     {"column", d.where.column},
                     {"message", d.message}});
  }
  return diags;
}

}  // namespace postproc::comp
