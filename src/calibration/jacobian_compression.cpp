// Tall-skinny QR of the weighted measurement Jacobian (jacobian_compression.hpp).
#include "src/calibration/jacobian_compression.hpp"

#include <algorithm>
#include <atomic>
#include <exception>
#include <thread>

#include <ceres/loss_function.h>
#include <Eigen/QR>

namespace postproc::cal::lsq {
namespace {

/// Measurements per chunk: a chunk's rows (≤ 6 per measurement) times k+1 columns stay in cache.
constexpr std::size_t kChunk = 512;

/// The upper triangle of the QR of `a` (rows × m), as an m×m matrix (zero rows below a short a).
Eigen::MatrixXd upper_of(const Eigen::MatrixXd& a) {
  const Eigen::Index m = a.cols();
  Eigen::MatrixXd r = Eigen::MatrixXd::Zero(m, m);
  if (a.rows() == 0) return r;
  const Eigen::HouseholderQR<Eigen::MatrixXd> qr(a);
  const Eigen::Index top = std::min(a.rows(), m);
  r.topRows(top) = qr.matrixQR().topRows(top).triangularView<Eigen::Upper>();
  return r;
}

/// One chunk's share: its R, its sums, and the first measurement that failed.
struct ChunkResult {
  Eigen::MatrixXd r;
  double squared = 0;
  double cost = 0;
  long rows = 0;
  std::ptrdiff_t failed = -1;
};

}  // namespace

void append_rows(Linearised& lin, const Eigen::MatrixXd& rows) {
  const Eigen::Index m = lin.aug.cols();
  Eigen::MatrixXd stacked(m + rows.rows(), m);
  stacked << lin.aug, rows;
  lin.aug = upper_of(stacked);
}

Linearised linearise(const kin::Model& model, std::span<const Measurement> data, std::span<const int> columns,
                     std::span<const Weights> weights, std::span<const FrameState> frames,
                     std::span<const int> frame_of, std::span<const FrameColumns> frame_columns, bool numeric,
                     const LineariseOptions& options) {
  Evaluator ev(model, std::vector<int>(columns.begin(), columns.end()), numeric);
  ev.set(model.values());
  const int nj = model.joint_count();
  int k = static_cast<int>(columns.size());
  for (const FrameColumns& f : frame_columns) k += static_cast<int>(f.components.size());
  std::vector<int> where(columns.size());
  for (std::size_t c = 0; c < columns.size(); ++c) where[c] = static_cast<int>(c);
  const int stride = k + 1;

  Linearised out;
  if (options.per_measurement) out.per_measurement.assign(data.size(), 0.0);
  const std::size_t chunks = (data.size() + kChunk - 1) / kChunk;
  std::vector<ChunkResult> results(chunks);

  const auto run_chunk = [&](std::size_t chunk, Eigen::MatrixXd& d, std::vector<double>& res) {
    ChunkResult& cr = results[chunk];
    const std::size_t begin = chunk * kChunk, end = std::min(data.size(), begin + kChunk);
    long rows = 0;
    for (std::size_t i = begin; i < end; ++i) rows += residual_rows(data[i], nj);
    Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> buf =
        Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>::Zero(rows, stride);
    long at = 0;
    for (std::size_t i = begin; i < end; ++i) {
      const Measurement& m = data[i];
      const int f = frame_of.empty() ? -1 : frame_of[i];
      const auto fi = static_cast<std::size_t>(f);
      const int n = residual_rows(m, nj);
      res.resize(static_cast<std::size_t>(n));
      double* row = buf.data() + at * stride;
      if (!measurement_rows(ev, m, weights[i], f >= 0 ? &frames[fi] : nullptr,
                            f >= 0 && fi < frame_columns.size() ? &frame_columns[fi] : nullptr, where, d, res.data(),
                            row, stride)) {
        cr.failed = static_cast<std::ptrdiff_t>(i);
        return;
      }
      double s = 0;
      for (double v : res) s += v * v;
      cr.squared += s;
      double scale = 1;
      if (options.loss != nullptr) {
        double rho[3];
        options.loss->Evaluate(s, rho);
        cr.cost += 0.5 * rho[0];
        scale = std::sqrt(std::max(rho[1], 0.0));
      } else {
        cr.cost += 0.5 * s;
      }
      for (int r = 0; r < n; ++r) {
        row[r * stride + k] = res[static_cast<std::size_t>(r)];
        if (scale != 1)
          for (int c = 0; c < stride; ++c) row[r * stride + c] *= scale;
      }
      if (options.per_measurement) out.per_measurement[i] = s;
      at += n;
    }
    cr.rows = rows;
    cr.r = upper_of(buf);
  };

  bool struts = false;
  for (const Measurement& m : data) struts = struts || m.kind == MeasurementKind::struts;
  const int threads =
      ev.all_analytic() && !struts ? std::clamp(options.threads, 1, static_cast<int>(std::max<std::size_t>(chunks, 1)))
                                   : 1;
  std::atomic<std::size_t> next{0};
  std::exception_ptr error;
  std::mutex error_mutex;
  const auto worker = [&] {
    Eigen::MatrixXd d;
    std::vector<double> res;
    try {
      for (std::size_t c = next++; c < chunks; c = next++) run_chunk(c, d, res);
    } catch (...) {
      const std::lock_guard<std::mutex> lock(error_mutex);
      if (!error) error = std::current_exception();
    }
  };
  if (threads <= 1) {
    worker();
  } else {
    std::vector<std::thread> pool;
    for (int t = 0; t < threads; ++t) pool.emplace_back(worker);
    for (std::thread& t : pool) t.join();
  }
  if (error) std::rethrow_exception(error);

  out.aug = Eigen::MatrixXd::Zero(stride, stride);
  for (const ChunkResult& cr : results) {
    if (cr.failed >= 0) {
      out.failed = cr.failed;
      return out;
    }
    out.squared += cr.squared;
    out.cost += cr.cost;
    out.rows += cr.rows;
    append_rows(out, cr.r);
  }
  return out;
}

}  // namespace postproc::cal::lsq
