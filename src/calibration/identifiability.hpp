#pragma once
// The identifiability analysis of identify() over labelled columns (machine parameters and
// instrument-frame components alike); identify.hpp's analyse() is its public form.
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "postproc/calibration/identify.hpp"

namespace postproc::cal {

/// "rad", "mm" or "(ratio)": a parameter's unit in reports.
[[nodiscard]] std::string unit_text(const kin::Parameter& p);

/// A column's name and unit for the identifiability report.
struct Label {
  std::string name, unit;
};

/// analyse() over labelled columns: dependent and unobserved are local column indices. `rows`:
/// the residual components when j is a compressed Jacobian (R of its QR; −1: j's own rows).
[[nodiscard]] Identifiability analyse_labelled(const Eigen::MatrixXd& j, std::span<const Label> labels,
                                               double rank_tolerance, long rows = -1);

/// analyse() of a compressed Jacobian (R of the QR of one with `rows` rows).
[[nodiscard]] Identifiability analyse_rows(const Eigen::MatrixXd& j, std::span<const int> columns,
                                           const kin::Model& model, double rank_tolerance, long rows);

/// The labels of parameters `columns` of `model`.
[[nodiscard]] std::vector<Label> labels_of(const kin::Model& model, std::span<const int> columns);

}  // namespace postproc::cal
