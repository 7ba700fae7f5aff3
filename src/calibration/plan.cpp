// Calibration planning: D-optimal choice of measuring poses, simulated measurements and the NC
// program that visits the poses (see plan.hpp).
#include "postproc/calibration/plan.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <random>
#include <utility>

#include <Eigen/Cholesky>
#include <fmt/format.h>

#include "postproc/error.hpp"
#include "postproc/gcode/dialect.hpp"
#include "postproc/gcode/motion.hpp"
#include "postproc/machine/program_map.hpp"
#include "postproc/gcode/resolve.hpp"

namespace postproc::cal {
namespace {

using Vec3 = Eigen::Vector3d;
/// The small r × r blocks of one candidate (r ≤ 8 rows: 6 pose rows or one per strut).
using Small = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kin::kMaxJoints, kin::kMaxJoints>;

constexpr double kUnlimitedMm = 300;   // draw range of a linear joint without limits, ±mm
constexpr double kUnlimitedDeg = 180;  // of a rotary joint without limits, ±degrees
constexpr int kDrawsPerCandidate = 50; // parallel models: give up after this many draws per candidate

bool is_parallel(const kin::Model& model) {
  const std::string k = model.kind();
  return k.find("prs_hybrid") != std::string::npos || k.find("hexapod") != std::string::npos;
}

bool free_torsion(const kin::Model& model) { return model.kind().find("hexapod") != std::string::npos; }

/// Travel of joint j with the margin applied (unlimited ends replaced by the documented ranges).
std::pair<double, double> travel(const kin::Joint& joint, double margin) {
  const double wide = joint.type == kin::JointType::rotary ? kUnlimitedDeg : kUnlimitedMm;
  const double lo = std::isfinite(joint.min) ? joint.min + margin : -wide;
  const double hi = std::isfinite(joint.max) ? joint.max - margin : wide;
  if (lo > hi)
    throw Error(ExitCode::usage, fmt::format("calibrate plan: margin {} leaves no travel on joint {} ({} .. {})", margin,
                                             joint.name, joint.min, joint.max));
  return {lo, hi};
}

bool within(const kin::Model& model, const kin::JointVector& q, double margin) {
  for (int j = 0; j < model.joint_count(); ++j) {
    const kin::Joint& joint = model.joints()[static_cast<std::size_t>(j)];
    if (!std::isfinite(q[j])) return false;
    if (std::isfinite(joint.min) && q[j] < joint.min + margin - 1e-9) return false;
    if (std::isfinite(joint.max) && q[j] > joint.max - margin + 1e-9) return false;
  }
  return true;
}

kin::Pose home_pose(const kin::Model& model) {
  kin::Pose home;
  const kin::JointVector zero = kin::JointVector::Zero(model.joint_count());
  if (!model.forward(zero, home).ok())
    throw Error(ExitCode::usage, "calibrate plan: forward kinematics fails at q = 0 (the home pose of the draws)");
  return home;
}

/// Random candidates (see plan.hpp): joints uniform in the travel, or for parallel models from
/// tool poses around home through the inverse kinematics.
std::vector<kin::JointVector> draw_candidates(const kin::Model& model, const PlanOptions& o, std::mt19937_64& rng,
                                              int& draws) {
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  const int n = model.joint_count();
  std::vector<kin::JointVector> out;
  out.reserve(static_cast<std::size_t>(o.candidates));
  draws = 0;
  // The region's joint ranges, intersected with the travel.
  auto in_region = [&](const kin::JointVector& q) {
    for (std::size_t j = 0; j < o.joint_region.size() && j < static_cast<std::size_t>(q.size()); ++j)
      if (q[static_cast<Eigen::Index>(j)] < o.joint_region[j].first || q[static_cast<Eigen::Index>(j)] > o.joint_region[j].second)
        return false;
    return true;
  };
  if (!is_parallel(model)) {
    std::vector<std::pair<double, double>> range;
    for (const kin::Joint& j : model.joints()) range.push_back(travel(j, o.margin));
    for (std::size_t j = 0; j < o.joint_region.size() && j < range.size(); ++j) {
      range[j].first = std::max(range[j].first, o.joint_region[j].first);
      range[j].second = std::min(range[j].second, o.joint_region[j].second);
      if (!(range[j].first <= range[j].second))
        throw Error(ExitCode::usage, fmt::format("calibrate plan: the region leaves no travel on joint {}",
                                                 model.joints()[j].name));
    }
    while (static_cast<int>(out.size()) < o.candidates && draws < kDrawsPerCandidate * o.candidates) {
      ++draws;
      kin::JointVector q(n);
      for (int j = 0; j < n; ++j) {
        const auto [lo, hi] = range[static_cast<std::size_t>(j)];
        q[j] = lo + (hi - lo) * unit(rng);
      }
      kin::Pose p;
      if (model.forward(q, p).ok()) out.push_back(q);
    }
    return out;
  }
  for (const kin::Joint& j : model.joints()) (void)travel(j, o.margin);  // reports a margin too large
  const kin::Pose home = home_pose(model);
  const kin::JointVector zero = kin::JointVector::Zero(n);
  const double cos_max = std::cos(o.max_tilt_deg * kin::kDeg);
  kin::IkOptions ik;
  ik.match = kin::PoseMatch::point_and_axis;
  ik.check_limits = false;
  while (static_cast<int>(out.size()) < o.candidates && draws < kDrawsPerCandidate * o.candidates) {
    ++draws;
    kin::Pose target;
    for (int k = 0; k < 3; ++k)
      target.p[k] = o.tip_region ? o.tip_region->first[k] + (o.tip_region->second[k] - o.tip_region->first[k]) * unit(rng)
                                 : home.p[k] + o.box_mm[k] * (2 * unit(rng) - 1);
    // Uniform over the cap: cos θ uniform in [cos θmax, 1].
    const double ct = 1 - (1 - cos_max) * unit(rng);
    const double st = std::sqrt(std::max(0.0, 1 - ct * ct));
    const double phi = 2 * kin::kPi * unit(rng);
    const Vec3 v(st * std::cos(phi), st * std::sin(phi), ct);  // axis in the home tool frame
    target.r = home.r * Eigen::Quaterniond::FromTwoVectors(Vec3::UnitZ(), v).toRotationMatrix();
    kin::JointVector q;
    if (!model.inverse(target, zero, q, ik).ok() || !within(model, q, o.margin) || !in_region(q)) continue;
    kin::Pose back;
    if (!model.forward(q, back).ok() || (back.p - target.p).norm() > 1e-6 ||
        (back.axis() - target.axis()).norm() > 1e-8)
      continue;
    out.push_back(q);
  }
  return out;
}

double log_det_spd(const Small& a) {
  const Eigen::LLT<Small> l(a);
  double ld = 0;
  for (Eigen::Index k = 0; k < a.rows(); ++k) ld += 2 * std::log(l.matrixL()(k, k));
  return ld;
}

/// The information M = εI + Σ J_iᵀJ_i of a set of candidates (rows r each of the scaled Jacobian
/// `js`), with every candidate's S_i = J_i M⁻¹ J_iᵀ kept up to date by Woodbury updates, so that
/// adding or removing one pose costs one (rows × p × r) product instead of a solve per candidate.
class Design {
  using Rows = Eigen::Block<const Eigen::MatrixXd, Eigen::Dynamic, Eigen::Dynamic, false>;
  [[nodiscard]] Rows block(Eigen::Index i) const { return js_.middleRows(i * r_, r_); }

 public:
  Design(const Eigen::MatrixXd& js, int r, double eps) : js_(js), r_(r), eps_(eps), s_(static_cast<std::size_t>(js.rows() / r)) {
    q_.resize(static_cast<Eigen::Index>(s_.size()), js.cols());
    for (Eigen::Index i = 0; i < q_.rows(); ++i) q_.row(i) = block(i).colwise().squaredNorm();
  }

  /// Rebuilds from scratch (also clears the drift of many updates).
  void reset(std::span<const int> chosen) {
    const Eigen::Index p = js_.cols();
    Eigen::MatrixXd m = eps_ * Eigen::MatrixXd::Identity(p, p);
    for (const int i : chosen) m.noalias() += block(i).transpose() * block(i);
    diag_ = m.diagonal();
    const Eigen::LLT<Eigen::MatrixXd> llt(m);
    log_det_ = 0;
    for (Eigen::Index k = 0; k < p; ++k) log_det_ += 2 * std::log(llt.matrixL()(k, k));
    minv_ = llt.solve(Eigen::MatrixXd::Identity(p, p));
    const Eigen::MatrixXd x = js_ * minv_;
    for (Eigen::Index i = 0; i < q_.rows(); ++i) s_[static_cast<std::size_t>(i)] = x.middleRows(i * r_, r_) * block(i).transpose();
  }

  /// log det(I + S_i): the gain of adding candidate i.
  [[nodiscard]] double gain(Eigen::Index i) const { return log_det_spd(plus_identity(s_[static_cast<std::size_t>(i)])); }
  [[nodiscard]] Eigen::Index count() const { return q_.rows(); }
  [[nodiscard]] double log_det() const { return log_det_; }
  /// log det of the column-normalised information: log det M − Σ log M_cc (scale invariant).
  [[nodiscard]] double normalised() const { return log_det_ - diag_.array().log().sum(); }

  /// Adds (sign +1) or removes (−1) candidate k.
  void update(Eigen::Index k, int sign) {
    Small a;
    Eigen::MatrixXd c;
    prepare(k, sign, a, c);
    const Eigen::MatrixXd u = minv_ * block(k).transpose();
    minv_.noalias() -= static_cast<double>(sign) * (u * a * u.transpose());
    for (Eigen::Index i = 0; i < count(); ++i) s_[static_cast<std::size_t>(i)] -= static_cast<double>(sign) * shifted(c, i, a);
    diag_ += static_cast<double>(sign) * q_.row(k).transpose();
    log_det_ -= log_det_spd(a);  // + log det(I + S_k) when adding, + log det(I − S_k) when removing
  }

  /// Best swap for chosen candidate k (taken marks the chosen ones): the candidate j whose
  /// exchange for k most increases the normalised criterion, and that increase (≤ 0: none).
  std::pair<Eigen::Index, double> best_swap(Eigen::Index k, const std::vector<char>& taken) const {
    Small a;
    Eigen::MatrixXd c;
    prepare(k, -1, a, c);
    const Eigen::VectorXd d = diag_ - q_.row(k).transpose();  // diagonal without k
    // Criterion change of the swap k → j: gain_j(M₋ₖ) − gain_k(M₋ₖ) − Σ_c log((d_c + q_jc) / M_cc),
    // with gain_k(M₋ₖ) = log det (I − S_k)⁻¹.
    const double gk = log_det_spd(a);
    std::pair<Eigen::Index, double> best{k, 0.0};
    for (Eigen::Index j = 0; j < count(); ++j) {
      if (taken[static_cast<std::size_t>(j)]) continue;
      const Small sj = s_[static_cast<std::size_t>(j)] + shifted(c, j, a);
      const double change = log_det_spd(plus_identity(sj)) - gk -
                            ((d + q_.row(j).transpose()).array() / diag_.array()).log().sum();
      if (change > best.second) best = {j, change};
    }
    return best;
  }

 private:
  [[nodiscard]] Small plus_identity(Small s) const {
    s = (0.5 * (s + s.transpose())).eval();
    s.diagonal().array() += 1.0;
    return s;
  }
  /// A = (I ± S_k)⁻¹ and C = J M⁻¹ J_kᵀ for all candidates.
  void prepare(Eigen::Index k, int sign, Small& a, Eigen::MatrixXd& c) const {
    Small i_s = static_cast<double>(sign) * s_[static_cast<std::size_t>(k)];
    i_s = (0.5 * (i_s + i_s.transpose())).eval();
    i_s.diagonal().array() += 1.0;
    a = i_s.inverse();
    c = js_ * (minv_ * block(k).transpose());
  }
  [[nodiscard]] Small shifted(const Eigen::MatrixXd& c, Eigen::Index i, const Small& a) const {
    const auto ci = c.middleRows(i * r_, r_);
    return ci * a * ci.transpose();
  }

  const Eigen::MatrixXd& js_;
  int r_;
  double eps_;
  std::vector<Small> s_;
  Eigen::MatrixXd q_;  // candidates × p: squared column norms of each candidate's block
  Eigen::MatrixXd minv_;
  Eigen::VectorXd diag_;
  double log_det_ = 0;
};

/// Nearest-neighbour tour from the candidate nearest q = 0 (joint space, mm and degrees alike).
std::vector<int> visiting_order(const std::vector<kin::JointVector>& cand, std::vector<int> chosen) {
  std::vector<int> out;
  kin::JointVector at = kin::JointVector::Zero(cand.front().size());
  while (!chosen.empty()) {
    std::size_t best = 0;
    double d = std::numeric_limits<double>::infinity();
    for (std::size_t k = 0; k < chosen.size(); ++k) {
      const double dk = (cand[static_cast<std::size_t>(chosen[k])] - at).squaredNorm();
      if (dk < d) {
        d = dk;
        best = k;
      }
    }
    out.push_back(chosen[best]);
    at = cand[static_cast<std::size_t>(chosen[best])];
    chosen.erase(chosen.begin() + static_cast<std::ptrdiff_t>(best));
  }
  return out;
}

Identifiability analyse_set(const kin::Model& model, std::span<const kin::JointVector> joints,
                            const PlanOptions& o, std::span<const int> cols) {
  const auto data = predicted_measurements(model, joints, o.kind, o.has_torsion);
  Eigen::VectorXd res;
  Eigen::MatrixXd jac;
  linearise(model, data, cols, res, jac, o.orientation_weight);
  return analyse(jac, cols, model);
}

}  // namespace

std::vector<Measurement> predicted_measurements(const kin::Model& model, std::span<const kin::JointVector> joints,
                                                MeasurementKind kind, bool has_torsion) {
  std::vector<Measurement> out;
  out.reserve(joints.size());
  for (const kin::JointVector& q : joints) {
    Measurement m;
    m.kind = kind;
    m.q = q;
    m.label = fmt::format("p{}", out.size() + 1);
    m.has_torsion = kind == MeasurementKind::struts || has_torsion;
    if (!model.forward(q, m.measured).ok())
      throw Error(ExitCode::usage, fmt::format("{}: forward kinematics fails at these joints", m.label));
    out.push_back(std::move(m));
  }
  return out;
}

PlanResult plan_poses(const kin::Model& model, const PlanOptions& o) {
  const auto t0 = std::chrono::steady_clock::now();
  if (o.poses < 1) throw Error(ExitCode::usage, fmt::format("calibrate plan: {} poses requested", o.poses));
  if (o.candidates < o.poses)
    throw Error(ExitCode::usage,
                fmt::format("calibrate plan: {} candidates cannot give {} distinct poses", o.candidates, o.poses));
  PlanResult result;
  const int np = static_cast<int>(model.parameters().size());
  if (o.parameters.empty()) {
    for (int k = 0; k < np; ++k)
      if (model.parameters()[static_cast<std::size_t>(k)].error) result.parameters.push_back(k);
  } else {
    for (const int k : o.parameters)
      if (k < 0 || k >= np)
        throw Error(ExitCode::usage, fmt::format("calibrate plan: parameter index {} outside 0..{}", k, np - 1));
    result.parameters = o.parameters;
  }
  if (result.parameters.empty()) throw Error(ExitCode::usage, "calibrate plan: the model has no error parameters");
  const std::span<const int> cols(result.parameters);

  std::mt19937_64 rng(o.seed);
  const std::vector<kin::JointVector> cand = draw_candidates(model, o, rng, result.draws);
  result.candidates = static_cast<int>(cand.size());
  if (result.candidates < o.poses)
    throw Error(ExitCode::usage, fmt::format("calibrate plan: only {} reachable candidates in {} draws for {} poses "
                                             "(enlarge the work volume or reduce the margin)",
                                             result.candidates, result.draws, o.poses));

  // The stacked Jacobian of every candidate, columns scaled to one unit of energy per candidate.
  const auto data = predicted_measurements(model, cand, o.kind, o.has_torsion);
  Eigen::VectorXd res;
  Eigen::MatrixXd jac;
  linearise(model, data, cols, res, jac, o.orientation_weight);
  const int r = residual_rows(data.front(), model.joint_count());
  result.all = analyse(jac, cols, model);
  const double per = std::sqrt(static_cast<double>(cand.size()));
  for (Eigen::Index c = 0; c < jac.cols(); ++c) {
    const double s = jac.col(c).norm() / per;
    if (s > 0) jac.col(c) /= s;
  }

  // Greedy: add the candidate with the largest gain log det(I + S_i), distinct poses only.
  std::vector<int> chosen;
  std::vector<char> taken(cand.size(), 0);
  Design design(jac, r, o.epsilon);
  design.reset(chosen);
  for (int step = 0; step < o.poses; ++step) {
    Eigen::Index best = -1;
    double best_gain = -std::numeric_limits<double>::infinity();
    for (Eigen::Index i = 0; i < design.count(); ++i) {
      if (taken[static_cast<std::size_t>(i)]) continue;
      if (const double g = design.gain(i); g > best_gain) {
        best_gain = g;
        best = i;
      }
    }
    chosen.push_back(static_cast<int>(best));
    taken[static_cast<std::size_t>(best)] = 1;
    design.update(best, +1);
  }
  design.reset(chosen);
  result.log_det_greedy = design.normalised();

  // Fedorov exchange on the column-normalised criterion (what analyse()'s O1 measures): swap a
  // chosen pose for the candidate that most increases it, while one does.
  for (int pass = 0; pass < o.exchange_passes; ++pass) {
    int swaps = 0;
    for (std::size_t t = 0; t < chosen.size(); ++t) {
      const int k = chosen[t];
      const auto [j, change] = design.best_swap(k, taken);
      if (j == k || change <= 1e-9) continue;
      design.update(k, -1);
      design.update(j, +1);
      taken[static_cast<std::size_t>(k)] = 0;
      taken[static_cast<std::size_t>(j)] = 1;
      chosen[t] = static_cast<int>(j);
      ++swaps;
    }
    design.reset(chosen);
    result.exchanges += swaps;
    if (swaps == 0) break;
  }
  result.log_det = design.normalised();

  for (const int i : visiting_order(cand, chosen)) result.joints.push_back(cand[static_cast<std::size_t>(i)]);
  result.planned = analyse_set(model, result.joints, o, cols);

  // The same number of random candidates (distinct), for comparison.
  std::vector<int> idx(cand.size());
  for (std::size_t i = 0; i < idx.size(); ++i) idx[i] = static_cast<int>(i);
  std::mt19937_64 pick(o.seed ^ 0x9e3779b97f4a7c15ULL);
  for (std::size_t i = 0; i < static_cast<std::size_t>(o.poses); ++i) {
    std::uniform_int_distribution<std::size_t> u(i, idx.size() - 1);
    std::swap(idx[i], idx[u(pick)]);
  }
  idx.resize(static_cast<std::size_t>(o.poses));
  std::vector<kin::JointVector> random;
  for (const int i : idx) random.push_back(cand[static_cast<std::size_t>(i)]);
  result.random = analyse_set(model, random, o, cols);
  design.reset(idx);
  result.log_det_random = design.normalised();
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

namespace {

/// Collects the working region of a program's motions through the controller's map.
class RegionVisitor final : public gcode::BlockVisitor {
 public:
  RegionVisitor(const machine::Machine& m, WorkingRegion& r)
      : m_(m), r_(r), models_(m), vectors_(m), start_(kin::JointVector::Zero(m.nominal->joint_count())) {
    kin::Pose home;
    if (m.nominal->forward(start_, home).ok()) home_axis_ = home.axis();
  }
  void block(const gcode::Block&, std::span<const gcode::Motion> motions, bool) override {
    for (const gcode::Motion& raw : motions) {
      const gcode::Motion mo = vectors_.apply(raw);
      const machine::Form f = machine::form_of(m_, mo);
      const gcode::AxisMask need = machine::written_axes(m_, f);
      if ((mo.known & need) != need || mo.type == gcode::MotionType::drill_cycle) continue;
      const auto map = machine::map_of(m_, models_, mo);
      if (!map) continue;
      kin::JointVector q;
      kin::Pose p;
      if (!map->joints(machine::Command{mo.end, mo.tool_vector}, start_, q).ok() || !m_.nominal->forward(q, p).ok()) continue;
      start_ = q;
      for (int j = 0; j < q.size(); ++j) {
        r_.joint_min[static_cast<std::size_t>(j)] = std::min(r_.joint_min[static_cast<std::size_t>(j)], q[j]);
        r_.joint_max[static_cast<std::size_t>(j)] = std::max(r_.joint_max[static_cast<std::size_t>(j)], q[j]);
      }
      if (r_.joints.size() < WorkingRegion::kMaxRegionJoints) r_.joints.push_back(q);
      r_.tip_min = r_.tip_min.cwiseMin(p.p);
      r_.tip_max = r_.tip_max.cwiseMax(p.p);
      r_.max_tilt_deg = std::max(r_.max_tilt_deg,
                                 std::acos(std::clamp(p.axis().dot(home_axis_), -1.0, 1.0)) / kin::kDeg);
      ++r_.motions;
    }
  }

 private:
  const machine::Machine& m_;
  WorkingRegion& r_;
  machine::ToolLengthModels models_;
  machine::ModalToolVector vectors_;
  kin::JointVector start_;
  Vec3 home_axis_ = Vec3::UnitZ();
};

}  // namespace

WorkingRegion program_region(const machine::Machine& m, std::span<const std::string> programs,
                             gcode::DiagnosticSink& sink) {
  WorkingRegion r;
  const int n = m.nominal->joint_count();
  r.joint_min.assign(static_cast<std::size_t>(n), std::numeric_limits<double>::infinity());
  r.joint_max.assign(static_cast<std::size_t>(n), -std::numeric_limits<double>::infinity());
  const gcode::Dialect d = *gcode::make_dialect(m.dialect_name, m.dialect_options);
  for (const std::string& path : programs) {
    RegionVisitor v(m, r);
    (void)gcode::run_program_file(path, d, path, sink, v, gcode::with_program_folder({}, path));
  }
  if (r.motions == 0)
    throw Error(ExitCode::usage, "calibrate plan --region-from: no motion of the program(s) has a known position on "
                                 "this machine; check the programs and the machine file");
  return r;
}

void plan_in(const WorkingRegion& r, const kin::Model& model, PlanOptions& o, double widen_mm) {
  o.joint_region.clear();
  const bool parallel = is_parallel(model);
  for (int j = 0; j < model.joint_count(); ++j) {
    const kin::Joint& joint = model.joints()[static_cast<std::size_t>(j)];
    // Serial joints are drawn in the program's own ranges; the joints of a parallel machine only
    // keep the draws (tool poses in the region) inside what the program needs, widened.
    const double w = parallel && joint.type != kin::JointType::rotary ? widen_mm : 0.0;
    o.joint_region.emplace_back(r.joint_min[static_cast<std::size_t>(j)] - w, r.joint_max[static_cast<std::size_t>(j)] + w);
  }
  if (parallel) {
    o.tip_region = std::make_pair(Vec3(r.tip_min - Vec3::Constant(widen_mm)), Vec3(r.tip_max + Vec3::Constant(widen_mm)));
    o.max_tilt_deg = std::max(1.0, r.max_tilt_deg);
  }
}

std::vector<Measurement> simulate_measurements(const kin::Model& truth, const kin::Model& controller,
                                               std::span<const kin::JointVector> commanded,
                                               const SimulateOptions& o) {
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::vector<Measurement> out;
  out.reserve(commanded.size());
  for (const kin::JointVector& q : commanded) {
    Measurement m;
    m.kind = o.kind;
    m.label = fmt::format("p{}", out.size() + 1);
    m.has_torsion = o.kind == MeasurementKind::struts || o.has_torsion;
    m.validate = o.validate_every > 0 && (out.size() + 1) % static_cast<std::size_t>(o.validate_every) == 0;
    if (o.kind == MeasurementKind::struts) {
      if (!controller.forward(q, m.measured).ok())
        throw Error(ExitCode::usage, fmt::format("{}: the controller model cannot evaluate the commanded joints", m.label));
      kin::IkOptions ik;
      ik.match = kin::PoseMatch::full;
      ik.check_limits = false;
      if (!truth.inverse(m.measured, q, m.q, ik).ok())
        throw Error(ExitCode::usage, fmt::format("{}: the true machine cannot reach the set pose", m.label));
      for (int j = 0; j < m.q.size(); ++j) m.q[j] += o.noise_mm * u(rng);
    } else {
      m.q = q;
      if (!truth.forward(q, m.measured).ok())
        throw Error(ExitCode::usage, fmt::format("{}: the true machine cannot evaluate the commanded joints", m.label));
      const Vec3 dp(u(rng), u(rng), u(rng));
      const Vec3 dth(u(rng), u(rng), u(rng));
      m.measured.p += o.noise_mm * dp;
      const Vec3 w = o.noise_deg * kin::kDeg * dth;
      if (w.norm() > 0) m.measured.r = Eigen::AngleAxisd(w.norm(), w.normalized()).toRotationMatrix() * m.measured.r;
    }
    out.push_back(std::move(m));
  }
  return out;
}

namespace {

/// A program word's number: fixed decimals, no "-0", a decimal point where the dialect needs one.
std::string number(double v, int decimals, bool point) {
  std::string s = fmt::format("{:.{}f}", v, std::max(decimals, 0));
  if (s.find_first_not_of("-0.") == std::string::npos && s.front() == '-') s.erase(0, 1);
  if (point && s.find('.') == std::string::npos) s += '.';
  return s;
}

struct Writer {
  const machine::Machine& m;
  gcode::Dialect d;
  std::string out;

  [[nodiscard]] bool fanuc() const { return d.id == gcode::DialectId::fanuc; }
  [[nodiscard]] bool siemens() const { return d.id == gcode::DialectId::siemens; }
  [[nodiscard]] std::string comment(std::string_view text) const {
    std::string t(text);
    if (d.paren_comments) {
      std::replace(t.begin(), t.end(), '(', '[');
      std::replace(t.begin(), t.end(), ')', ']');
      return "(" + t + ")";
    }
    return "; " + t;
  }
  void line(std::string_view s) {
    out += s;
    out += '\n';
  }
  [[nodiscard]] std::string word(int axis, double v) const {
    return fmt::format(" {}{}", gcode::kAxisLetters[static_cast<std::size_t>(axis)],
                       number(v, m.decimals(axis), d.decimal_point_required));
  }
  [[nodiscard]] std::string vector(const Vec3& o) const {
    if (siemens()) return fmt::format(" A3={} B3={} C3={}", number(o.x(), 6, false), number(o.y(), 6, false),
                                      number(o.z(), 6, false));
    return fmt::format(" I{} J{} K{}", number(o.x(), 6, true), number(o.y(), 6, true), number(o.z(), 6, true));
  }
};

/// Virtual angles (degrees) of a tool axis, O = Rx(A)·Ry(B)·ẑ = (sin B, −sin A cos B, cos A cos B):
/// the inverse of how machine/program_map.cpp reads A and B.
Eigen::Vector2d virtual_ab(const Vec3& axis) {
  const Vec3 u = axis.normalized();
  return {std::atan2(-u.y(), u.z()) / kin::kDeg, std::asin(std::clamp(u.x(), -1.0, 1.0)) / kin::kDeg};
}

}  // namespace

std::string plan_program(const machine::Machine& machine, std::span<const kin::JointVector> poses,
                         std::string_view title) {
  const auto dialect = gcode::make_dialect(machine.dialect_name, machine.dialect_options);
  if (!dialect) throw Error(ExitCode::usage, fmt::format("calibrate plan: unknown dialect '{}'", machine.dialect_name));
  Writer w{machine, *dialect, {}};
  if (!w.fanuc() && !w.siemens() && w.d.id != gcode::DialectId::linuxcnc)
    throw Error(ExitCode::usage, fmt::format("calibrate plan: cannot write a {} program yet", machine.dialect_name));
  const bool tool_tip = machine.coordinates == machine::ProgramCoordinates::tool_tip;
  const bool vector = tool_tip && machine.orientation == machine::Orientation::vector;
  if (tool_tip && machine.orientation == machine::Orientation::rotary_axes)
    throw Error(ExitCode::usage, "calibrate plan: tool-tip programs with rotary axis values are not written");
  if (vector && w.d.id == gcode::DialectId::linuxcnc)
    throw Error(ExitCode::usage, "calibrate plan: linuxcnc has no tool-vector programming");
  const kin::Model& nominal = *machine.nominal;
  gcode::AxisVector offset = gcode::AxisVector::Zero();
  if (const auto it = machine.work_offsets.find("G54"); it != machine.work_offsets.end()) offset = it->second;

  // Program start.
  if (!w.siemens()) w.line("%");
  if (w.fanuc()) w.line(fmt::format("O0001 {}", w.comment(title)));
  else w.line(w.comment(title));
  w.line(w.comment(fmt::format("calibration poses: {}, machine: {}", poses.size(), machine.name)));
  w.line(w.comment("the program moves straight from pose to pose: check the path for collisions"));
  if (tool_tip)
    w.line(w.comment(vector ? "tool-tip program with tool vector: expects the machine's TCP mode"
                            : "tool-tip program with virtual A B: expects the machine's TCP mode"));
  w.line(w.siemens() ? "G17 G90 G54 G71" : "G21 G90 G94 G17 G54");
  std::string activate;  // on the first motion block
  if (vector) {
    if (w.siemens()) {
      w.line("TRAORI");
    } else {
      activate = " G43.5";
      if (!machine.tool_lengths.empty()) activate += fmt::format(" H{}", machine.tool_lengths.begin()->first);
    }
  }

  const auto tool_tip_words = [&](const kin::Pose& p) {
    std::string s;
    for (int a = 0; a < 3; ++a) s += w.word(a, p.p[a] - offset[a]);
    if (vector) {
      s += w.vector(p.axis());
    } else {
      const Eigen::Vector2d ab = virtual_ab(p.axis());
      s += w.word(3, ab[0] - offset[3]) + w.word(4, ab[1] - offset[4]);
    }
    return s;
  };
  kin::Pose home;
  const bool via_home = tool_tip && free_torsion(nominal);
  if (via_home && !nominal.forward(kin::JointVector::Zero(nominal.joint_count()), home).ok())
    throw Error(ExitCode::usage, "calibrate plan: forward kinematics fails at the home pose (q = 0)");

  for (std::size_t k = 0; k < poses.size(); ++k) {
    const kin::JointVector& q = poses[k];
    if (q.size() != nominal.joint_count())
      throw Error(ExitCode::usage, fmt::format("calibrate plan: pose p{} has {} joints, the machine {}", k + 1, q.size(),
                                               nominal.joint_count()));
    std::string words;
    if (tool_tip) {
      kin::Pose p;
      if (!nominal.forward(q, p).ok())
        throw Error(ExitCode::usage, fmt::format("calibrate plan: forward kinematics fails at pose p{}", k + 1));
      if (via_home) {
        w.line(fmt::format("G0{}{} {}", std::exchange(activate, std::string()), tool_tip_words(home),
                           w.comment("home: the rotation about the tool axis starts from home")));
      }
      words = tool_tip_words(p);
    } else {
      for (int a = 0; a < gcode::kAxisCount; ++a) {
        const int j = machine.joint_of_axis[static_cast<std::size_t>(a)];
        if (j >= 0 && j < q.size()) words += w.word(a, q[j] - offset[a]);
      }
    }
    w.line(fmt::format("G90 G0{}{}", std::exchange(activate, std::string()), words));
    w.line(fmt::format("M0 {}", w.comment(fmt::format("measure pose p{}", k + 1))));
  }
  if (vector) w.line(w.siemens() ? "TRAFOOF" : "G49");
  w.line("M30");
  if (!w.siemens()) w.line("%");
  return w.out;
}

}  // namespace postproc::cal
