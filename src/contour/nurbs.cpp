#include "postproc/contour/nurbs.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <string>

#include "postproc/error.hpp"

namespace postproc::contour {
namespace {

constexpr int kDegree = CubicCurve::degree;

[[noreturn]] void usage(const std::string& what) { throw Error(ExitCode::usage, what); }

/// Non-zero basis functions N_{s−3..s} at u in span s (A2.2).
std::array<double, 4> basis(const std::vector<double>& U, std::size_t s, double u) {
  std::array<double, 4> N{1.0, 0.0, 0.0, 0.0};
  std::array<double, 4> left{}, right{};
  for (int j = 1; j <= kDegree; ++j) {
    const auto uj = static_cast<std::size_t>(j);
    left[uj] = u - U[s + 1 - uj];
    right[uj] = U[s + uj] - u;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      const auto ur = static_cast<std::size_t>(r);
      const double temp = N[ur] / (right[ur + 1] + left[uj - ur]);
      N[ur] = saved + right[ur + 1] * temp;
      saved = left[uj - ur] * temp;
    }
    N[uj] = saved;
  }
  return N;
}

/// Basis functions and their first two derivatives in span s (A2.3 with n = 2): ders[k][j].
std::array<std::array<double, 4>, 3> basis_derivatives(const std::vector<double>& U, std::size_t s, double u) {
  double ndu[4][4] = {};
  double left[4] = {}, right[4] = {};
  ndu[0][0] = 1.0;
  for (int j = 1; j <= kDegree; ++j) {
    left[j] = u - U[s + 1 - static_cast<std::size_t>(j)];
    right[j] = U[s + static_cast<std::size_t>(j)] - u;
    double saved = 0.0;
    for (int r = 0; r < j; ++r) {
      ndu[j][r] = right[r + 1] + left[j - r];  // lower triangle: knot differences
      const double temp = ndu[r][j - 1] / ndu[j][r];
      ndu[r][j] = saved + right[r + 1] * temp;
      saved = left[j - r] * temp;
    }
    ndu[j][j] = saved;
  }
  std::array<std::array<double, 4>, 3> ders{};
  for (int j = 0; j <= kDegree; ++j) ders[0][static_cast<std::size_t>(j)] = ndu[j][kDegree];
  constexpr int n = 2;
  for (int r = 0; r <= kDegree; ++r) {
    double a[2][4] = {};
    int s1 = 0, s2 = 1;
    a[0][0] = 1.0;
    for (int k = 1; k <= n; ++k) {
      double d = 0.0;
      const int rk = r - k, pk = kDegree - k;
      if (r >= k) {
        a[s2][0] = a[s1][0] / ndu[pk + 1][rk];
        d = a[s2][0] * ndu[rk][pk];
      }
      const int j1 = rk >= -1 ? 1 : -rk;
      const int j2 = (r - 1 <= pk) ? k - 1 : kDegree - r;
      for (int j = j1; j <= j2; ++j) {
        a[s2][j] = (a[s1][j] - a[s1][j - 1]) / ndu[pk + 1][rk + j];
        d += a[s2][j] * ndu[rk + j][pk];
      }
      if (r <= pk) {
        a[s2][k] = -a[s1][k - 1] / ndu[pk + 1][r];
        d += a[s2][k] * ndu[r][pk];
      }
      ders[static_cast<std::size_t>(k)][static_cast<std::size_t>(r)] = d;
      std::swap(s1, s2);
    }
  }
  double factor = kDegree;
  for (std::size_t k = 1; k <= n; ++k) {
    for (auto& v : ders[k]) v *= factor;
    factor *= static_cast<double>(kDegree - static_cast<int>(k));
  }
  return ders;
}

/// Symmetric positive-definite banded matrix (half-bandwidth 3), Cholesky-factored in place.
/// band[i][d] holds A(i, i − d).
class BandedSpd {
 public:
  explicit BandedSpd(std::size_t n) : band_(n, std::array<double, 4>{}) {}
  void add(std::size_t i, std::size_t j, double v) {  // i ≥ j, i − j ≤ 3
    band_[i][i - j] += v;
  }
  /// Factors A = L·Lᵀ; false when a pivot is not positive (singular normal matrix).
  bool factor() {
    const std::size_t n = band_.size();
    for (std::size_t i = 0; i < n; ++i) {
      const std::size_t lo = i >= 3 ? i - 3 : 0;
      for (std::size_t j = lo; j <= i; ++j) {
        double s = band_[i][i - j];
        for (std::size_t k = lo; k < j; ++k) s -= band_[i][i - k] * band_[j][j - k];
        if (i == j) {
          if (!(s > 0.0)) return false;
          band_[i][0] = std::sqrt(s);
        } else {
          band_[i][i - j] = s / band_[j][0];
        }
      }
    }
    return true;
  }
  /// Solves L·Lᵀ x = b in place.
  void solve(std::vector<Eigen::Vector3d>& b) const {
    const std::size_t n = band_.size();
    for (std::size_t i = 0; i < n; ++i) {
      for (std::size_t k = i >= 3 ? i - 3 : 0; k < i; ++k) b[i] -= band_[i][i - k] * b[k];
      b[i] /= band_[i][0];
    }
    for (std::size_t i = n; i-- > 0;) {
      for (std::size_t k = i + 1; k < std::min(n, i + 4); ++k) b[i] -= band_[k][k - i] * b[k];
      b[i] /= band_[i][0];
    }
  }

 private:
  std::vector<std::array<double, 4>> band_;
};

/// Clamped knot vector for n control points over parameters ub (strictly increasing, 0 … 1).
std::vector<double> knots_for(const std::vector<double>& ub, std::size_t n) {
  const std::size_t m = ub.size() - 1;  // points Q_0 … Q_m; control points P_0 … P_{n−1}
  std::vector<double> U(n + 4, 0.0);
  for (std::size_t j = 0; j < 4; ++j) U[n + j] = 1.0;
  const std::size_t interior = n - 4;  // knots U[4] … U[n−1]
  if (n == m + 1) {                     // interpolation: eq. 9.8
    for (std::size_t j = 1; j <= interior; ++j) U[j + 3] = (ub[j] + ub[j + 1] + ub[j + 2]) / 3.0;
  } else {  // least squares: eq. 9.69 with d = (m + 1)/(n − p)
    const double d = static_cast<double>(m + 1) / static_cast<double>(n - 3);
    for (std::size_t j = 1; j <= interior; ++j) {
      const double jd = static_cast<double>(j) * d;
      const auto i = static_cast<std::size_t>(jd);
      const double alpha = jd - static_cast<double>(i);
      U[j + 3] = (1.0 - alpha) * ub[i - 1] + alpha * ub[i];
    }
  }
  return U;
}

/// Least-squares fit with the end points fixed (eq. 9.63–9.67) for n control points.
std::vector<Eigen::Vector3d> solve_ls(const std::vector<Eigen::Vector3d>& Q, const std::vector<double>& ub,
                                      const std::vector<double>& U, std::size_t n) {
  const std::size_t m = Q.size() - 1;
  std::vector<Eigen::Vector3d> P(n, Eigen::Vector3d::Zero());
  P.front() = Q.front();
  P.back() = Q.back();
  const std::size_t unknowns = n - 2;  // P_1 … P_{n−2}
  BandedSpd A(unknowns);
  std::vector<Eigen::Vector3d> rhs(unknowns, Eigen::Vector3d::Zero());
  for (std::size_t k = 1; k < m; ++k) {
    const double u = ub[k];
    const auto it = std::upper_bound(U.begin() + 4, U.begin() + static_cast<std::ptrdiff_t>(n), u);
    const auto s = static_cast<std::size_t>(it - U.begin()) - 1;
    const auto N = basis(U, s, u);
    Eigen::Vector3d R = Q[k];
    for (std::size_t a = 0; a < 4; ++a) {
      const std::size_t c = s - 3 + a;
      if (c == 0) R -= N[a] * Q.front();
      if (c == n - 1) R -= N[a] * Q.back();
    }
    for (std::size_t a = 0; a < 4; ++a) {
      const std::size_t c = s - 3 + a;
      if (c == 0 || c == n - 1) continue;
      rhs[c - 1] += N[a] * R;
      for (std::size_t b = 0; b <= a; ++b) {
        const std::size_t c2 = s - 3 + b;
        if (c2 == 0) continue;
        A.add(c - 1, c2 - 1, N[a] * N[b]);
      }
    }
  }
  if (!A.factor()) {
    if (n == m + 1)
      throw Error(ExitCode::internal, "fit_cubic: singular interpolation matrix with " + std::to_string(n) +
                                          " control points");
    return {};  // a knot span without data (Schoenberg–Whitney): the caller interpolates instead
  }
  A.solve(rhs);
  for (std::size_t c = 0; c < unknowns; ++c) P[c + 1] = rhs[c];
  return P;
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// CubicCurve

CubicCurve::CubicCurve()
    : knots_{0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0}, control_points_(4, Eigen::Vector3d::Zero()) {}

CubicCurve::CubicCurve(std::vector<double> knots, std::vector<Eigen::Vector3d> control_points)
    : knots_(std::move(knots)), control_points_(std::move(control_points)) {
  const std::size_t n = control_points_.size();
  if (n < 4) usage("CubicCurve: needs at least 4 control points, got " + std::to_string(n));
  if (knots_.size() != n + 4)
    usage("CubicCurve: expected " + std::to_string(n + 4) + " knots for " + std::to_string(n) +
          " control points, got " + std::to_string(knots_.size()));
  for (std::size_t i = 0; i < knots_.size(); ++i) {
    if (!std::isfinite(knots_[i])) usage("CubicCurve: knot " + std::to_string(i) + " is not finite");
    if (i > 0 && knots_[i] < knots_[i - 1]) usage("CubicCurve: knot " + std::to_string(i) + " decreases");
  }
  if (knots_[0] != knots_[3] || knots_[n] != knots_[n + 3]) usage("CubicCurve: knot vector is not clamped");
  if (!(knots_[3] < knots_[n])) usage("CubicCurve: empty parameter domain");
  for (std::size_t i = 0; i < n; ++i)
    if (!control_points_[i].allFinite()) usage("CubicCurve: control point " + std::to_string(i) + " is not finite");
}

CubicCurve::Domain CubicCurve::domain() const { return {knots_[3], knots_[size()]}; }

std::size_t CubicCurve::span(double u) const {
  const std::size_t n = size();
  const auto it = std::upper_bound(knots_.begin() + 4, knots_.begin() + static_cast<std::ptrdiff_t>(n), u);
  return static_cast<std::size_t>(it - knots_.begin()) - 1;  // in [3, n − 1]
}

Eigen::Vector3d CubicCurve::point(double u) const {
  const Domain d = domain();
  u = std::clamp(u, d.begin, d.end);
  const std::size_t s = span(u);
  const auto N = basis(knots_, s, u);
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (std::size_t a = 0; a < 4; ++a) c += N[a] * control_points_[s - 3 + a];
  return c;
}

CubicCurve::Derivatives CubicCurve::evaluate(double u) const {
  const Domain d = domain();
  u = std::clamp(u, d.begin, d.end);
  const std::size_t s = span(u);
  const auto D = basis_derivatives(knots_, s, u);
  Derivatives r;
  for (std::size_t a = 0; a < 4; ++a) {
    const Eigen::Vector3d& P = control_points_[s - 3 + a];
    r.point += D[0][a] * P;
    r.first += D[1][a] * P;
    r.second += D[2][a] * P;
  }
  return r;
}

// ---------------------------------------------------------------------------------------------
// Fitting

FitResult fit_cubic(std::span<const Eigen::Vector3d> points, const FitOptions& options) {
  if (points.empty()) usage("fit_cubic: no points");
  if (!(options.tolerance_mm > 0.0)) usage("fit_cubic: tolerance_mm must be > 0, got " + std::to_string(options.tolerance_mm));
  for (std::size_t i = 0; i < points.size(); ++i)
    if (!points[i].allFinite()) usage("fit_cubic: point " + std::to_string(i) + " is not finite");

  // Distinct points (runs of duplicates collapsed) and their centripetal parameters.
  std::vector<Eigen::Vector3d> Q;
  std::vector<std::size_t> index_of(points.size());  // input point → distinct point
  std::vector<double> ub;
  Q.push_back(points[0]);
  ub.push_back(0.0);
  for (std::size_t i = 1; i < points.size(); ++i) {
    const double step = (points[i] - Q.back()).norm();
    if (step > options.duplicate_mm) {
      Q.push_back(points[i]);
      ub.push_back(ub.back() + std::sqrt(step));
    }
    index_of[i] = Q.size() - 1;
  }
  const std::size_t N = Q.size();
  if (N > 1) {
    const double total = ub.back();
    for (double& u : ub) u /= total;
    ub.back() = 1.0;
  }

  FitResult result;
  std::vector<double> U;
  std::vector<Eigen::Vector3d> P;
  if (N <= 3) {
    U = {0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0};
    if (N == 1) {
      P.assign(4, Q[0]);
    } else if (N == 2) {  // the segment, u ∝ arc length
      ub[1] = 1.0;
      for (int k = 0; k < 4; ++k) P.push_back(Q[0] + (Q[1] - Q[0]) * (k / 3.0));
    } else {  // the parabola through the 3 points at 0, t, 1, degree-elevated
      const double t = ub[1];
      const Eigen::Vector3d mid =
          (Q[1] - (1.0 - t) * (1.0 - t) * Q[0] - t * t * Q[2]) / (2.0 * t * (1.0 - t));
      P = {Q[0], (Q[0] + 2.0 * mid) / 3.0, (2.0 * mid + Q[2]) / 3.0, Q[2]};
    }
    result.curve = CubicCurve(U, P);
    result.rounds = 1;
  } else {
    const std::size_t cap = options.max_control_points == 0 ? N : std::clamp<std::size_t>(options.max_control_points, 4, N);
    std::size_t n = std::min(cap, std::min(N, 4 + N / 8));
    for (;;) {
      // Close to one control point per point, eq. 9.69 can leave a knot span without data (a
      // singular normal matrix): interpolate instead.
      if (cap == N && n < N && 10 * n > 7 * N) n = N;
      U = knots_for(ub, n);
      P = solve_ls(Q, ub, U, n);
      if (P.empty()) {
        n = N;
        U = knots_for(ub, n);
        P = solve_ls(Q, ub, U, n);
      }
      result.curve = CubicCurve(U, P);
      ++result.rounds;
      double worst = 0.0;
      for (std::size_t k = 0; k < N; ++k) worst = std::max(worst, (result.curve.point(ub[k]) - Q[k]).norm());
      if (worst <= options.tolerance_mm || n >= cap) break;
      const double grow = std::clamp(1.1 * std::pow(worst / options.tolerance_mm, 0.25), 1.25, 4.0);
      n = std::min(cap, std::max(n + 1, static_cast<std::size_t>(std::ceil(static_cast<double>(n) * grow))));
    }
  }

  result.params.resize(points.size());
  double sum2 = 0.0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    result.params[i] = ub[index_of[i]];
    const double r = (result.curve.point(result.params[i]) - points[i]).norm();
    result.max_residual_mm = std::max(result.max_residual_mm, r);
    sum2 += r * r;
  }
  result.rms_residual_mm = std::sqrt(sum2 / static_cast<double>(points.size()));
  result.control_points = result.curve.size();
  result.within_tolerance = result.max_residual_mm <= options.tolerance_mm;
  return result;
}

// ---------------------------------------------------------------------------------------------
// Windows

void for_each_window(std::span<const Eigen::Vector3d> points, std::size_t window, std::size_t overlap,
                     const FitOptions& options, const std::function<void(FitPiece&&)>& visit) {
  if (window < 4) usage("fit_windows: window must be ≥ 4 points, got " + std::to_string(window));
  if (overlap >= window)
    usage("fit_windows: overlap (" + std::to_string(overlap) + ") must be < window (" + std::to_string(window) + ")");
  if (points.empty()) usage("fit_windows: no points");
  const std::size_t n = points.size();
  const std::size_t step = window - overlap;
  for (std::size_t begin = 0;; begin += step) {
    // The last piece ends at the last point and is shifted back to a full window.
    const std::size_t b = begin + window >= n ? (n > window ? n - window : 0) : begin;
    const std::size_t e = std::min(n, b + window);
    FitPiece piece;
    piece.begin = b;
    piece.end = e;
    piece.fit = fit_cubic(points.subspan(b, e - b), options);
    visit(std::move(piece));
    if (e == n) break;
  }
}

WindowedFit fit_windows(std::span<const Eigen::Vector3d> points, std::size_t window, std::size_t overlap,
                        const FitOptions& options) {
  WindowedFit w;
  w.points = points.size();
  for_each_window(points, window, overlap, options, [&](FitPiece&& piece) { w.pieces.push_back(std::move(piece)); });
  return w;
}

const FitPiece& WindowedFit::piece_for(std::size_t i) const {
  if (i >= points || pieces.empty())
    usage("WindowedFit: point " + std::to_string(i) + " out of range (" + std::to_string(points) + " points)");
  // Pieces are sorted by begin; those containing i are just before the first with begin > i.
  auto it = std::upper_bound(pieces.begin(), pieces.end(), i, [](std::size_t v, const FitPiece& f) { return v < f.begin; });
  const FitPiece* best = nullptr;
  std::size_t best_margin = 0;
  while (it != pieces.begin()) {
    --it;
    if (it->end <= i) {
      if (best) break;
      continue;
    }
    const std::size_t margin = std::min(i - it->begin, it->end - 1 - i);
    if (!best || margin >= best_margin) {  // going backwards: ≥ prefers the earlier piece on a tie
      best = &*it;
      best_margin = margin;
    }
  }
  if (!best) usage("WindowedFit: no piece holds point " + std::to_string(i));
  return *best;
}

bool WindowedFit::within_tolerance() const {
  return std::all_of(pieces.begin(), pieces.end(), [](const FitPiece& f) { return f.fit.within_tolerance; });
}

double WindowedFit::max_residual_mm() const {
  double m = 0.0;
  for (const FitPiece& f : pieces) m = std::max(m, f.fit.max_residual_mm);
  return m;
}

// ---------------------------------------------------------------------------------------------
// Foot point

ProjectResult project(const CubicCurve& curve, const Eigen::Vector3d& q, double u0, const ProjectOptions& options) {
  const CubicCurve::Domain dom = curve.domain();
  auto dist = [&](double u) { return (curve.point(u) - q).norm(); };
  // Distances are only known to rounding (∝ the size of the coordinates): an "increase" below this
  // is noise, and treating it as divergence would hand a converged answer to Newton.
  const double slack = 64.0 * std::numeric_limits<double>::epsilon() * (1.0 + q.norm() + curve.point(u0).norm());
  auto worse = [&](double dn, double d) { return dn > d + slack; };

  // Local search from u: back-estimation, then Newton.
  auto local = [&](double u) {
    ProjectResult r;
    u = std::clamp(u, dom.begin, dom.end);
    CubicCurve::Derivatives D = curve.evaluate(u);
    double d = (D.point - q).norm();
    bool newton = false;
    for (int it = 0; it < options.max_back_estimation; ++it) {
      const double speed2 = D.first.squaredNorm();
      if (!(speed2 > 0.0)) {
        newton = true;
        break;
      }
      const double un = std::clamp(u + (q - D.point).dot(D.first) / speed2, dom.begin, dom.end);
      const double moved = std::abs(un - u) * std::sqrt(speed2);
      ++r.iterations;
      if (moved <= options.step_tolerance_mm) {
        r.converged = true;
        break;
      }
      const CubicCurve::Derivatives Dn = curve.evaluate(un);
      const double dn = (Dn.point - q).norm();
      if (worse(dn, d)) {  // overshoot (d·κ > 1 on the convex side) or a wrong way: hand over to Newton
        newton = true;
        break;
      }
      u = un;
      D = Dn;
      d = dn;
    }
    if (!r.converged) newton = true;
    if (newton) {
      r.method = ProjectMethod::newton;
      for (int it = 0; it < options.max_newton; ++it) {
        const Eigen::Vector3d e = D.point - q;
        const double speed2 = D.first.squaredNorm();
        const double f = e.dot(D.first);
        const double fp = speed2 + e.dot(D.second);
        double du = fp > 1e-12 * speed2 ? -f / fp : (speed2 > 0.0 ? -f / speed2 : 0.0);
        ++r.iterations;
        double un = std::clamp(u + du, dom.begin, dom.end);
        if (std::abs(un - u) * std::sqrt(speed2) <= options.step_tolerance_mm) {
          r.converged = true;
          break;
        }
        CubicCurve::Derivatives Dn = curve.evaluate(un);
        double dn = (Dn.point - q).norm();
        for (int h = 0; h < 40 && worse(dn, d); ++h) {  // halving line search on the distance
          du *= 0.5;
          un = std::clamp(u + du, dom.begin, dom.end);
          Dn = curve.evaluate(un);
          dn = (Dn.point - q).norm();
        }
        if (worse(dn, d)) {  // no descent along f: u is a (numerical) minimum
          r.converged = true;
          break;
        }
        u = un;
        D = Dn;
        d = dn;
      }
    }
    r.u = u;
    r.point = D.point;
    r.distance = d;
    return r;
  };

  ProjectResult best = local(u0);
  if (options.check_ends) {
    for (const double ue : {dom.begin, dom.end}) {
      const double de = dist(ue);
      if (de < best.distance) {
        const int its = best.iterations;
        best = local(ue);
        best.iterations += its;
        best.method = ProjectMethod::global;
      }
    }
  }
  if (options.samples_per_span > 0) {
    const auto& U = curve.knots();
    double us = best.u, ds = best.distance;
    for (std::size_t s = 3; s + 1 < U.size() - 3; ++s) {
      if (!(U[s] < U[s + 1])) continue;
      for (int k = 0; k <= options.samples_per_span; ++k) {
        const double u = U[s] + (U[s + 1] - U[s]) * k / options.samples_per_span;
        const double d = dist(u);
        if (d < ds) {
          ds = d;
          us = u;
        }
      }
    }
    if (ds < best.distance - 1e-12) {
      const int its = best.iterations;
      ProjectResult again = local(us);
      if (again.distance < best.distance) {
        best = again;
        best.iterations += its;
        best.method = ProjectMethod::global;
      }
    }
  }
  return best;
}

}  // namespace postproc::contour
