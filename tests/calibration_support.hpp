#pragma once
// Shared helpers of the calibration tests: sample paths, the start model of an identification,
// random joint vectors inside the travel. Tests that include it define POSTPROC_SOURCE_DIR.
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include "postproc/calibration/measurement.hpp"
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

/// Document 003's strut readings: at `count` poses where the nominal NC sets the platform (a
/// quarter of random joint vectors, well inside the travel), the struts the true machine needs
/// there plus ±0.5 µm of noise. Fewer when a pose cannot be reached.
inline std::vector<postproc::cal::Measurement> hexapod_strut_readings(const postproc::kin::Model& truth,
                                                                      const postproc::kin::Model& nominal,
                                                                      std::size_t count) {
  using namespace postproc;
  std::vector<cal::Measurement> data;
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(-1, 1);
  for (const auto& q : random_joints(truth, 60, 31)) {
    cal::Measurement m;
    m.kind = cal::MeasurementKind::struts;
    m.q = q * 0.25;
    if (!nominal.forward(m.q, m.measured).ok()) continue;  // the set pose: where the nominal NC thinks it is
    kin::IkOptions o;
    o.match = kin::PoseMatch::full;
    o.check_limits = false;
    kin::JointVector rec;
    if (!truth.inverse(m.measured, m.q, rec, o).ok()) continue;
    for (int j = 0; j < 6; ++j) rec[j] += 0.0005 * u(rng);
    m.q = rec;
    m.label = "s" + std::to_string(data.size() + 1);
    data.push_back(m);
    if (data.size() == count) break;
  }
  return data;
}

}  // namespace pptest
