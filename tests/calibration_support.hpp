#pragma once
// Shared helpers of the calibration tests: sample paths, the start model of an identification,
// random joint vectors inside the travel. Tests that include it define POSTPROC_SOURCE_DIR.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "postproc/kinematics/model.hpp"

namespace pptest {

/// A file under samples/ of the source tree.
inline std::string sample_path(const std::string& rel) { return std::string(POSTPROC_SOURCE_DIR) + "/samples/" + rel; }

/// The model with every error parameter at its nominal value (error-motion tables and geometry
/// kept): the start of an identification.
inline postproc::kin::ModelPtr zero_errors(const postproc::kin::Model& m) {
  std::vector<double> v = m.values();
  for (std::size_t k = 0; k < v.size(); ++k)
    if (m.parameters()[k].error) v[k] = m.parameters()[k].nominal;
  return m.with_values(v);
}

/// Random joint vectors inside the travel, `margin` (a fraction of each joint's travel) from its
/// ends; rotary joints without limits draw from ±180°. Deterministic for a seed.
inline std::vector<postproc::kin::JointVector> random_joints(const postproc::kin::Model& m, int n, unsigned seed,
                                                              double margin = 0) {
  std::mt19937 rng(seed);
  std::vector<postproc::kin::JointVector> out;
  for (int i = 0; i < n; ++i) {
    postproc::kin::JointVector q(m.joint_count());
    for (int j = 0; j < m.joint_count(); ++j) {
      const postproc::kin::Joint& jt = m.joints()[static_cast<std::size_t>(j)];
      const double lo = std::isfinite(jt.min) ? jt.min : -180, hi = std::isfinite(jt.max) ? jt.max : 180;
      q[j] = std::uniform_real_distribution<double>(lo + margin * (hi - lo), hi - margin * (hi - lo))(rng);
    }
    out.push_back(q);
  }
  return out;
}

}  // namespace pptest
