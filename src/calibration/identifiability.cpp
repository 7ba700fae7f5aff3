// The identifiability analysis: SVD of the column-scaled identification Jacobian, the null
// directions named, the parameters to hold chosen by a rank-revealing QR (identifiability.hpp).
#include "src/calibration/identifiability.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/QR>
#include <Eigen/SVD>
#include <fmt/format.h>

namespace postproc::cal {

std::string unit_text(const kin::Parameter& p) { return p.unit == "rad" ? "rad" : p.unit == "ratio" ? "(ratio)" : "mm"; }

/// analyse() over labelled columns: dependent and unobserved are local column indices.
Identifiability analyse_labelled(const Eigen::MatrixXd& j, std::span<const Label> labels, double rank_tolerance,
                                 long rows) {
  Identifiability a;
  a.rows = static_cast<int>(rows >= 0 ? rows : j.rows());
  a.parameters = static_cast<int>(labels.size());
  std::vector<int> observed;
  std::vector<double> scale;
  double max_norm = 0;
  for (Eigen::Index c = 0; c < j.cols(); ++c) max_norm = std::max(max_norm, j.col(c).norm());
  for (Eigen::Index c = 0; c < j.cols(); ++c) {
    const double n = j.col(c).norm();
    if (n <= 1e-12 * std::max(max_norm, 1e-300)) {
      a.unobserved.push_back(static_cast<int>(c));
      a.dependent.push_back(static_cast<int>(c));
    } else {
      observed.push_back(static_cast<int>(c));
      scale.push_back(n);
    }
  }
  if (observed.empty()) return a;
  Eigen::MatrixXd js(j.rows(), static_cast<Eigen::Index>(observed.size()));
  for (std::size_t c = 0; c < observed.size(); ++c) js.col(static_cast<Eigen::Index>(c)) = j.col(observed[c]) / scale[c];
  // Full V: with fewer rows than columns the null directions beyond the rows are needed too.
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(js, Eigen::ComputeFullV);
  a.singular_values = svd.singularValues();
  const Eigen::Index m = a.singular_values.size();
  const double smax = a.singular_values[0];
  a.rank = 0;
  for (Eigen::Index i = 0; i < m; ++i)
    if (a.singular_values[i] > rank_tolerance * smax) ++a.rank;
  if (a.rank > 0) {
    const double smin = a.singular_values[a.rank - 1];
    a.condition = smax / smin;
    a.o3 = smin;
    a.o4 = smin * smin / smax;
    double log_sum = 0;
    for (int i = 0; i < a.rank; ++i) log_sum += std::log(a.singular_values[i]);
    a.o1 = std::exp(log_sum / a.rank) / std::sqrt(static_cast<double>(std::max(a.rows, 1)));
  }
  // Null directions: the columns of V beyond the rank (and all of them when rows < columns).
  const Eigen::MatrixXd v = svd.matrixV();
  auto combination = [&](Eigen::Index i) {
    Eigen::Index big = 0;
    v.col(i).cwiseAbs().maxCoeff(&big);
    const double ref = v(big, i) / scale[static_cast<std::size_t>(big)];
    std::string text;
    for (Eigen::Index c = 0; c < v.rows(); ++c) {
      if (std::abs(v(c, i)) < 0.05 * std::abs(v(big, i))) continue;
      const Label& l = labels[static_cast<std::size_t>(observed[static_cast<std::size_t>(c)])];
      text += fmt::format("{}{:+.3g} {} {}", text.empty() ? "" : ", ", v(c, i) / scale[static_cast<std::size_t>(c)] / ref,
                          l.unit, l.name);
    }
    return text;
  };
  for (Eigen::Index i = a.rank; i < v.cols(); ++i) a.combinations.push_back(combination(i));
  if (a.rank > 0) a.weakest = combination(a.rank - 1);
  // Which parameters to hold: the columns a rank-revealing QR puts last.
  const int nullity = static_cast<int>(observed.size()) - a.rank;
  if (nullity > 0) {
    const Eigen::ColPivHouseholderQR<Eigen::MatrixXd> qr(js);
    const auto& perm = qr.colsPermutation().indices();
    for (int i = a.rank; i < static_cast<int>(observed.size()); ++i)
      a.dependent.push_back(observed[static_cast<std::size_t>(perm[i])]);
  }
  std::sort(a.dependent.begin(), a.dependent.end());
  return a;
}

std::vector<Label> labels_of(const kin::Model& model, std::span<const int> columns) {
  std::vector<Label> out;
  for (int c : columns) {
    const kin::Parameter& p = model.parameters()[static_cast<std::size_t>(c)];
    out.push_back({p.name, unit_text(p)});
  }
  return out;
}


Identifiability analyse(const Eigen::MatrixXd& j, std::span<const int> columns, const kin::Model& model,
                        double rank_tolerance) {
  return analyse_rows(j, columns, model, rank_tolerance, -1);
}

Identifiability analyse_rows(const Eigen::MatrixXd& j, std::span<const int> columns, const kin::Model& model,
                             double rank_tolerance, long rows) {
  Identifiability a = analyse_labelled(j, labels_of(model, columns), rank_tolerance, rows);
  for (int& c : a.dependent) c = columns[static_cast<std::size_t>(c)];
  for (int& c : a.unobserved) c = columns[static_cast<std::size_t>(c)];
  std::sort(a.dependent.begin(), a.dependent.end());
  return a;
}

}  // namespace postproc::cal
