// Instrument frames while identify() estimates them (see frame_registration.hpp).
#include "src/calibration/frame_registration.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>
#include <Eigen/QR>
#include <Eigen/SVD>
#include <fmt/format.h>

#include "postproc/calibration/identify.hpp"
#include "postproc/error.hpp"
#include "src/calibration/identifiability.hpp"

namespace postproc::cal {
namespace {

/// Unit-norm columns and their norms.
Eigen::MatrixXd unit_columns(const Eigen::MatrixXd& j, Eigen::VectorXd& norms) {
  norms.resize(j.cols());
  Eigen::MatrixXd out(j.rows(), j.cols());
  for (Eigen::Index c = 0; c < j.cols(); ++c) {
    norms[c] = j.col(c).norm();
    out.col(c) = norms[c] > 1e-300 ? Eigen::VectorXd(j.col(c) / norms[c]) : Eigen::VectorXd::Zero(j.rows());
  }
  return out;
}

}  // namespace

/// exp(ω): the rotation by |ω| about ω.
Mat3 rotation_of(const Vec3& w) {
  const double a = w.norm();
  return a > 0 ? Eigen::AngleAxisd(a, w / a).toRotationMatrix() : Mat3::Identity();
}

/// An instrument frame's registration: P_w = exp(ω)·r0·P_i + t, with reg = (t, ω).
kin::Pose registered_pose(const kin::Pose& measured, const Mat3& r0, const double* reg) {
  const Mat3 r = rotation_of(Vec3(reg[3], reg[4], reg[5])) * r0;
  kin::Pose out;
  out.p = r * measured.p + Vec3(reg[0], reg[1], reg[2]);
  out.r = r * measured.r;
  return out;
}

/// Start values of each frame's registration: the rigid transform (no scale) that best carries
/// the measured points onto the start model's (Umeyama), or, for a frame with only tool axes,
/// the rotation that best carries the measured axes onto the model's (Kabsch). Only when every
/// component the data can move is free; otherwise the identity (the held components stay 0).
void start_registration(const kin::Model& model, std::span<const Measurement> fit, std::span<const int> frame_of,
                        std::vector<FrameState>& frames) {
  for (std::size_t f = 0; f < frames.size(); ++f) {
    std::vector<Vec3> src, dst, src_axis, dst_axis;
    for (std::size_t i = 0; i < fit.size(); ++i) {
      if (frame_of[i] != static_cast<int>(f)) continue;
      const Measurement& m = fit[i];
      kin::Pose p;
      if (!model.forward(m.q, p).ok()) continue;
      if (m.kind == MeasurementKind::pose || m.kind == MeasurementKind::position) {
        src.push_back(m.measured.p);
        dst.push_back(p.p);
      }
      if (m.kind == MeasurementKind::pose || m.kind == MeasurementKind::direction) {
        src_axis.push_back(m.measured.axis());
        dst_axis.push_back(p.axis());
      }
    }
    FrameState& fr = frames[f];
    const bool all = fr.free == (kTranslation | kRotation);
    if (!src.empty() && all && src.size() >= 3) {
      Eigen::Matrix3Xd a(3, static_cast<Eigen::Index>(src.size())), b(3, static_cast<Eigen::Index>(src.size()));
      for (std::size_t i = 0; i < src.size(); ++i) {
        a.col(static_cast<Eigen::Index>(i)) = src[i];
        b.col(static_cast<Eigen::Index>(i)) = dst[i];
      }
      const Eigen::Matrix3Xd centred = a.colwise() - a.rowwise().mean();
      const Eigen::JacobiSVD<Eigen::MatrixXd> spread(centred);
      if (spread.singularValues()[1] > 1e-6 * spread.singularValues()[0]) {  // not all on a line
        const Eigen::Matrix4d t = Eigen::umeyama(a, b, false);
        fr.r0 = t.topLeftCorner<3, 3>();
        for (int k = 0; k < 3; ++k) fr.reg[static_cast<std::size_t>(k)] = t(k, 3);
      }
    } else if (src.empty() && fr.free == kRotation && src_axis.size() >= 2) {
      Mat3 h = Mat3::Zero();
      for (std::size_t i = 0; i < src_axis.size(); ++i) h += src_axis[i] * dst_axis[i].transpose();
      const Eigen::JacobiSVD<Mat3> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
      if (svd.singularValues()[1] > 1e-6 * svd.singularValues()[0]) {  // two axes that are not parallel
        Mat3 d = Mat3::Identity();
        d(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1 : 1;
        fr.r0 = svd.matrixV() * d * svd.matrixU().transpose();
      }
    } else if (!src.empty() && (fr.free & kTranslation) == kTranslation && (fr.free & kRotation) == 0) {
      Vec3 mean = Vec3::Zero();
      for (std::size_t i = 0; i < src.size(); ++i) mean += dst[i] - src[i];
      mean /= static_cast<double>(src.size());
      for (int k = 0; k < 3; ++k) fr.reg[static_cast<std::size_t>(k)] = mean[k];
    }
  }
}

/// The instrument frames come first: a registration component is estimated unless no
/// measurement depends on it or the frames' components before it already explain it; a machine
/// parameter that the registration (and the machine parameters kept before it) explains within
/// `tolerance` (residual norm of its unit column) is held at its start value. The data cannot
/// tell such a parameter from where the instrument stood, so the machine file's value stays and
/// the unknown placement takes the difference (attributing it to the machine instead would move
/// the machine's model by the instrument's misregistration). Records why.
void separate_registration(const Eigen::MatrixXd& machine, const Eigen::MatrixXd& reg, std::span<const std::pair<int, int>> reg_of,
                           const kin::Model& model, std::vector<int>& identified, std::vector<int>& held,
                           std::vector<int>& dependent, std::vector<std::string>& machine_why,
                           std::vector<FrameState>& frames, std::vector<std::vector<std::string>>& frame_why,
                           double tolerance) {
  Eigen::VectorXd rnorm, mnorm;
  const Eigen::MatrixXd ru = unit_columns(reg, rnorm), mu = unit_columns(machine, mnorm);
  Eigen::MatrixXd q(reg.rows(), 0);
  std::vector<std::pair<int, int>> kept;  // registration components in the basis
  auto residual = [&](const Eigen::VectorXd& col) -> Eigen::VectorXd { return col - q * (q.transpose() * col); };
  auto add = [&](const Eigen::VectorXd& r) {
    q.conservativeResize(Eigen::NoChange, q.cols() + 1);
    q.col(q.cols() - 1) = r / r.norm();
  };
  for (Eigen::Index c = 0; c < reg.cols(); ++c) {
    const auto [f, k] = reg_of[static_cast<std::size_t>(c)];
    FrameState& fr = frames[static_cast<std::size_t>(f)];
    const bool zero = rnorm[c] <= 1e-300;
    const Eigen::VectorXd r = zero ? Eigen::VectorXd() : residual(ru.col(c));
    if (!zero && r.norm() > tolerance) {
      add(r);
      kept.emplace_back(f, k);
      continue;
    }
    fr.held = static_cast<std::uint8_t>(fr.held | (1u << k));
    frame_why[static_cast<std::size_t>(f)].push_back(
        zero ? fmt::format("{}: no measurement depends on it (held)", registration_name(k))
             : fmt::format("{}: the frame's other components already explain it (held)", registration_name(k)));
  }
  const Eigen::Index nreg = q.cols();
  std::vector<int> keep;
  for (std::size_t i = 0; i < identified.size(); ++i) {
    const Eigen::VectorXd col = mu.col(static_cast<Eigen::Index>(i));
    const Eigen::VectorXd r = residual(col);
    if (r.norm() > tolerance) {
      add(r);
      keep.push_back(identified[i]);
      continue;
    }
    // Which registration components explain it: the least-squares fit by the registration part.
    std::string text;
    if (nreg > 0) {
      Eigen::MatrixXd basis(reg.rows(), static_cast<Eigen::Index>(kept.size()));
      for (std::size_t c = 0; c < kept.size(); ++c) {
        const auto at = std::find(reg_of.begin(), reg_of.end(), kept[c]) - reg_of.begin();
        basis.col(static_cast<Eigen::Index>(c)) = ru.col(at);
      }
      const Eigen::VectorXd coef = basis.colPivHouseholderQr().solve(col);
      Eigen::Index big = 0;
      if (coef.size() > 0) coef.cwiseAbs().maxCoeff(&big);
      for (Eigen::Index c = 0; c < coef.size(); ++c) {
        if (std::abs(coef[c]) < 0.2 * std::abs(coef[big])) continue;
        const auto [f, k] = kept[static_cast<std::size_t>(c)];
        text += fmt::format("{}{}[{}]", text.empty() ? "" : ", ", registration_name(k), frames[static_cast<std::size_t>(f)].name);
      }
    }
    const kin::Parameter& p = model.parameters()[static_cast<std::size_t>(identified[i])];
    held.push_back(identified[i]);
    dependent.push_back(identified[i]);
    machine_why.push_back(fmt::format("{}: explained by the instrument frame's placement{}{} (held at the machine "
                                      "file's value: the data cannot tell them apart)",
                                      p.name, text.empty() ? "" : " ", text));
  }
  identified = keep;
  std::sort(held.begin(), held.end());
  std::sort(dependent.begin(), dependent.end());
}


Eigen::Vector3d FrameEstimate::rotation() const {
  const Eigen::AngleAxisd aa(r);
  return aa.angle() * aa.axis();
}

std::vector<Measurement> registered(std::span<const Measurement> data, const IdentifyResult& result) {
  std::vector<Measurement> out(data.begin(), data.end());
  for (Measurement& m : out) {
    if (m.source.frame.empty()) continue;
    const auto f = std::find_if(result.frames.begin(), result.frames.end(),
                                [&](const FrameEstimate& e) { return e.name == m.source.frame; });
    if (f == result.frames.end())
      throw Error(ExitCode::usage,
                  fmt::format("{}: this measurement is in instrument frame '{}', which no fitted measurement "
                              "determines; fit some measurements of the same set-up (or declare the frame of the "
                              "held-out file as the fitted file's: '# frame: instrument NAME')",
                              m.label, m.source.frame));
    m.measured.p = f->r * m.measured.p + f->t;
    m.measured.r = f->r * m.measured.r;
    m.source.frame.clear();
  }
  return out;
}

}  // namespace postproc::cal
