// The inverse-response fit's least-squares problem solved directly
// (calib/photometry/response_fit.h).
//
// Every residual of the fit is linear in its unknowns: w (h(Z) - ln E_p - ln t_j) with h linear
// between two knots, and the smoothing prior's second differences of h. Only the Huber loss
// makes the problem non-quadratic, and it is convex, so iteratively reweighted least squares
// (each residual weighted by rho'(r^2), the Huber weight) reaches the one minimum a general
// solver reaches. Each pixel's ln E enters only that pixel's residuals: its normal equation is
// one scalar, eliminated in closed form (the Schur complement, as bundle adjusters eliminate
// points), which leaves a dense system over the knots and the free exposure times (a few
// hundred unknowns however many pixels are sampled). docs/photometric.md "Speed" has the
// measured gain over the general solver this replaced.
#include <algorithm>
#include <cmath>

#include <fmt/format.h>
#include <Eigen/Cholesky>
#include <Eigen/Core>

#include "calib/photometry/response_fit.h"
#include "common/error.h"

namespace gonio {
namespace {

// The unknowns left free, numbered: knot k -> knot_index[k], frame j -> frame_index[j]; -1: held.
struct FreeIndex {
  std::vector<int> knot, frame;
  int size = 0;
};

FreeIndex NumberUnknowns(const LinearFitSpec& spec, const std::vector<KnotObservation>& obs) {
  FreeIndex f;
  f.knot.assign(spec.knot_fixed.size(), -1);
  f.frame.assign(spec.frame_fixed.size(), -1);
  for (size_t k = 0; k < spec.knot_fixed.size(); ++k) {
    if (!spec.knot_fixed[k]) f.knot[k] = f.size++;
  }
  // A frame enters the problem only through its observations.
  std::vector<bool> seen(spec.frame_fixed.size(), false);
  for (const auto& o : obs) seen[o.frame] = true;
  for (size_t j = 0; j < spec.frame_fixed.size(); ++j) {
    if (seen[j] && !spec.frame_fixed[j]) f.frame[j] = f.size++;
  }
  return f;
}

// One observation's terms: q = sum coef[m] y[index[m]] + constant - ln E_p.
struct Terms {
  int index[3];
  double coef[3];
  int n = 0;
  double constant = 0;
};

Terms TermsOf(const KnotObservation& o, const FreeIndex& f, const std::vector<double>& h,
              const std::vector<double>& ln_t) {
  Terms t;
  const auto add = [&](int index, double coef, double held_value) {
    if (index >= 0) {
      t.index[t.n] = index;
      t.coef[t.n++] = coef;
    } else {
      t.constant += coef * held_value;
    }
  };
  add(f.knot[o.k], 1 - o.a, h[o.k]);
  add(f.knot[o.k + 1], o.a, h[o.k + 1]);
  add(f.frame[o.frame], -1.0, ln_t[o.frame]);
  return t;
}

// The smoothing prior's normal equations (constant over the iterations): matrix and right-hand
// side over the free unknowns, held knots moved to the right.
void AddSmoothness(const LinearFitSpec& spec, const FreeIndex& f, const std::vector<double>& h,
                   Eigen::MatrixXd* normal, Eigen::VectorXd* rhs) {
  const int K = static_cast<int>(spec.knot_fixed.size());
  for (int k = 1; k + 1 < K; ++k) {
    const double w2 = spec.smooth_weight[k] * spec.smooth_weight[k];
    if (w2 == 0) continue;
    const int idx[3] = {f.knot[k - 1], f.knot[k], f.knot[k + 1]};
    const double coef[3] = {1.0, -2.0, 1.0};
    double constant = 0;
    for (int m = 0; m < 3; ++m) {
      if (idx[m] < 0) constant += coef[m] * h[k - 1 + m];
    }
    for (int m = 0; m < 3; ++m) {
      if (idx[m] < 0) continue;
      (*rhs)(idx[m]) -= w2 * coef[m] * constant;
      for (int n = 0; n < 3; ++n) {
        if (idx[n] >= 0) (*normal)(idx[m], idx[n]) += w2 * coef[m] * coef[n];
      }
    }
  }
}

// Observations grouped by pixel (indices into obs).
std::vector<std::vector<int>> ByPixel(const std::vector<KnotObservation>& obs, int num_pixels) {
  std::vector<std::vector<int>> by(num_pixels);
  for (size_t i = 0; i < obs.size(); ++i) by[obs[i].pixel].push_back(static_cast<int>(i));
  return by;
}

// The free knots and times as one vector of unknowns, and back.
Eigen::VectorXd PackUnknowns(const FreeIndex& f, const std::vector<double>& h,
                             const std::vector<double>& ln_t) {
  Eigen::VectorXd y(f.size);
  for (size_t k = 0; k < f.knot.size(); ++k) {
    if (f.knot[k] >= 0) y(f.knot[k]) = h[k];
  }
  for (size_t j = 0; j < f.frame.size(); ++j) {
    if (f.frame[j] >= 0) y(f.frame[j]) = ln_t[j];
  }
  return y;
}

void UnpackUnknowns(const FreeIndex& f, const Eigen::VectorXd& y, std::vector<double>* h,
                    std::vector<double>* ln_t) {
  for (size_t k = 0; k < f.knot.size(); ++k) {
    if (f.knot[k] >= 0) (*h)[k] = y(f.knot[k]);
  }
  for (size_t j = 0; j < f.frame.size(); ++j) {
    if (f.frame[j] >= 0) (*ln_t)[j] = y(f.frame[j]);
  }
}

// An observation's q at the unknowns y and its pixel's ln E = e.
double QOf(const Terms& t, const Eigen::VectorXd& y, double e) {
  double q = t.constant - e;
  for (int m = 0; m < t.n; ++m) q += t.coef[m] * y(t.index[m]);
  return q;
}

// Adds the observations' normal equations with weights omega to normal and rhs (on entry the
// prior's), each pixel's ln E eliminated. d: per pixel the sum of its weights (its ln E's
// normal equation), zero on entry.
void AddObservationsReduced(const std::vector<Terms>& terms,
                            const std::vector<std::vector<int>>& by_pixel,
                            const std::vector<double>& omega, Eigen::MatrixXd* normal,
                            Eigen::VectorXd* rhs, std::vector<double>* d) {
  const int n = static_cast<int>(normal->rows());
  // Scratch for one pixel's coupling to the free unknowns (g_p, sparse over `touched`).
  Eigen::VectorXd g = Eigen::VectorXd::Zero(n);
  std::vector<int> touched;
  std::vector<char> is_touched(n, 0);
  std::vector<double> b(by_pixel.size(), 0.0);
  for (size_t p = 0; p < by_pixel.size(); ++p) {
    if (by_pixel[p].empty()) continue;
    touched.clear();
    for (int i : by_pixel[p]) {
      const Terms& t = terms[i];
      (*d)[p] += omega[i];
      b[p] += omega[i] * t.constant;
      for (int m = 0; m < t.n; ++m) {
        (*rhs)(t.index[m]) -= omega[i] * t.coef[m] * t.constant;
        for (int k = 0; k < t.n; ++k) {
          (*normal)(t.index[m], t.index[k]) += omega[i] * t.coef[m] * t.coef[k];
        }
        if (!is_touched[t.index[m]]) {
          is_touched[t.index[m]] = 1;
          touched.push_back(t.index[m]);
        }
        g(t.index[m]) += omega[i] * t.coef[m];
      }
    }
    // ln E_p = (g_p . y + b_p) / d_p eliminated: normal -= g g^T / d, rhs += g b / d.
    for (int r : touched) {
      (*rhs)(r) += g(r) * b[p] / (*d)[p];
      for (int c : touched) (*normal)(r, c) -= g(r) * g(c) / (*d)[p];
    }
    for (int r : touched) g(r) = 0, is_touched[r] = 0;
  }
}

}  // namespace

double HuberWeight(double residual, double scale) {
  const double r = std::abs(residual);
  return r <= scale ? 1.0 : scale / r;
}

void SolveResponseFit(const std::vector<KnotObservation>& obs, const LinearFitSpec& spec,
                      std::vector<double>* h, std::vector<double>* ln_e, std::vector<double>* ln_t,
                      std::vector<double>* weights, Eigen::MatrixXd* normal_out) {
  const FreeIndex f = NumberUnknowns(spec, obs);
  const int n = f.size;
  const auto by_pixel = ByPixel(obs, static_cast<int>(ln_e->size()));
  std::vector<Terms> terms(obs.size());
  Eigen::MatrixXd prior = Eigen::MatrixXd::Zero(n, n);
  Eigen::VectorXd prior_rhs = Eigen::VectorXd::Zero(n);
  AddSmoothness(spec, f, *h, &prior, &prior_rhs);
  for (size_t i = 0; i < obs.size(); ++i) terms[i] = TermsOf(obs[i], f, *h, *ln_t);

  Eigen::VectorXd y = PackUnknowns(f, *h, *ln_t);
  std::vector<double> omega(obs.size());
  for (int iteration = 0; iteration < spec.max_iterations; ++iteration) {
    for (size_t i = 0; i < obs.size(); ++i) {
      const double w = obs[i].w;
      omega[i] = w * w * HuberWeight(w * QOf(terms[i], y, (*ln_e)[obs[i].pixel]), spec.huber_scale);
    }
    Eigen::MatrixXd normal = prior;
    Eigen::VectorXd rhs = prior_rhs;
    std::vector<double> d(by_pixel.size(), 0.0);
    AddObservationsReduced(terms, by_pixel, omega, &normal, &rhs, &d);
    // An unknown the data do not reach keeps its value (a ridge towards it on its empty row):
    // a free frame whose well-exposed pixels are well exposed in no other frame, so that each
    // one's ln E absorbs it (a sweep's longest exposures, where only the darkest ink is left).
    const double ridge = 1e-9 * (n > 0 ? normal.diagonal().cwiseAbs().maxCoeff() : 0.0) + 1e-12;
    for (int k = 0; k < n; ++k) {
      if (normal(k, k) > ridge) continue;
      normal(k, k) += ridge;
      rhs(k) += ridge * y(k);
    }
    const Eigen::LDLT<Eigen::MatrixXd> ldlt(normal);
    const Eigen::VectorXd y_new = ldlt.solve(rhs);
    if (ldlt.info() != Eigen::Success || !y_new.allFinite()) {
      throw NumericalError("response fit: the normal equations have no finite solution");
    }
    const double step = n > 0 ? (y_new - y).cwiseAbs().maxCoeff() : 0.0;
    y = y_new;
    for (size_t p = 0; p < by_pixel.size(); ++p) {
      if (by_pixel[p].empty()) continue;
      double num = 0;
      for (int i : by_pixel[p]) num += omega[i] * QOf(terms[i], y, 0.0);
      (*ln_e)[p] = num / d[p];
    }
    if (normal_out) *normal_out = normal;
    if (step < spec.tolerance) break;
  }
  UnpackUnknowns(f, y, h, ln_t);
  if (weights) *weights = std::move(omega);
}

}  // namespace gonio
