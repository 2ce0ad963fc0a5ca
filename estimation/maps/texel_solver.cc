#include "estimation/maps/texel_solver.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>

#include <ceres/jet.h>
#include <spdlog/spdlog.h>
#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>

#include "common/error.h"
#include "common/math.h"
#include "common/parallel.h"
#include "estimation/maps/texel_system.h"
#include "estimation/sfs/sfs_costs.h"

namespace gonio {

using namespace texel_internal;

namespace {

// Each view's part of a texel's gradient over its P + S local unknowns (TexelSystem's sink).
struct ViewGradients {
  std::vector<LocalVector>* per_view;
  void operator()(size_t v, int, const int* idx, const double* row, int nz, double z, double weight,
                  double) const {
    for (int a = 0; a < nz; ++a) (*per_view)[v](idx[a]) += weight * row[a] * z;
  }
};

// Texel t's standard deviations into `sd_out` from `cov`, the inverse of its own Gauss-Newton
// matrix, plus the shared values' covariance `cov_shared` (when given) carried through AiB (its
// dependence on them; `map`: its shared columns' global indices): albedo per channel, the
// normal's direction (RMS angle, degrees) and sigma (per texel, or its cluster's).
void TexelStandardDeviations(const Pass& s, size_t t, const State& x, LocalMatrix cov,
                             const LocalMatrix& AiB, const std::vector<int>& map,
                             const Eigen::MatrixXd* cov_shared, TexelFit* sd_out) {
  const int S = s.S();
  if (S > 0 && cov_shared) {
    LocalMatrix Cs(S, S);
    for (int a = 0; a < S; ++a) {
      for (int c = 0; c < S; ++c) Cs(a, c) = (*cov_shared)(map[a], map[c]);
    }
    cov += AiB * Cs * AiB.transpose();
  }
  const int cm = s.C * s.m;
  for (int k = 0; k < cm; ++k) sd_out->sd_w[t * cm + k] = std::sqrt(std::max(0.0, cov(k, k)));
  // Covariance of the unit normal n = u / |u|, u = (-p, -q, -1): dn/d(p, q).
  const Eigen::Vector3d u(-x.p, -x.q, -1.0);
  const double un = u.norm();
  const Eigen::Vector3d nn = u / un;
  const Eigen::Matrix3d dn = (Eigen::Matrix3d::Identity() - nn * nn.transpose()) / un;
  Eigen::Matrix<double, 3, 2> Jn;
  Jn.col(0) = -dn.col(0);
  Jn.col(1) = -dn.col(1);
  const Eigen::Matrix2d Cpq = cov.block(cm, cm, 2, 2);
  sd_out->sd_normal_deg[t] =
      static_cast<float>(RadToDeg(std::sqrt(std::max(0.0, (Jn * Cpq * Jn.transpose()).trace()))));
  if (s.per_texel_r()) {
    sd_out->sd_r[t] = std::sqrt(std::max(0.0, cov(cm + 2, cm + 2)));
  } else if (s.shared_r() && cov_shared) {
    const int k = (*s.cluster)[t];
    sd_out->sd_r[t] = std::sqrt(std::max(0.0, (*cov_shared)(k, k)));
  }
}

// Per texel the inverse of its own Gauss-Newton block, A^-1, and its coupling to its S shared
// values, A^-1 B (ReducedSystem), kept until the shared values' covariance is known: the
// standard deviations then need no second pass with derivatives (docs/maps.md "Full size").
struct TexelBlocks {
  int P = 0, S = 0;
  std::vector<double> values;  // per texel P P + P S, column-major
  double* At(size_t t) { return values.data() + t * (P * P + P * S); }
  const double* At(size_t t) const { return values.data() + t * (P * P + P * S); }
};

// The shared system reduced by every fitted texel (Schur complement at the texels' current
// values), plus the white reference. With `view_scores`, each view's part of the reduced
// gradient (its texel residuals only): what SharedFit::ViewScatter sums. With `blocks`, every
// fitted texel's A^-1 and A^-1 B.
template <typename Basis, int D>
void ReducedSystem(const Pass& s, const std::vector<State>& x, const TexelFit& fit,
                   Eigen::MatrixXd* H, Eigen::VectorXd* g,
                   std::vector<Eigen::VectorXd>* view_scores = nullptr,
                   TexelBlocks* blocks = nullptr) {
  const int G = s.GlobalShared();
  H->setZero(G, G);
  g->setZero(G);
  std::mutex mutex;
  const size_t n = x.size(), views = s.data->views.size();
  const int P = s.P(), S = s.S();
  if (view_scores) view_scores->assign(views, Eigen::VectorXd::Zero(G));
  if (blocks) {
    blocks->P = P, blocks->S = S;
    blocks->values.assign(n * (P * P + P * S), 0.0);
  }
  ParallelFor(n, s.options->threads, [&](size_t b, size_t e) {
    Eigen::MatrixXd Hl = Eigen::MatrixXd::Zero(G, G);
    Eigen::VectorXd gl = Eigen::VectorXd::Zero(G);
    std::vector<Eigen::VectorXd> scores(view_scores ? views : 0, Eigen::VectorXd::Zero(G));
    std::vector<LocalVector> per_view(view_scores ? views : 0);
    std::vector<int> map;
    LocalMatrix Ht;
    LocalVector gt;
    for (size_t t = b; t < e; ++t) {
      if (!fit.fitted[t]) continue;
      const bool scored = view_scores && S > 0 && s.Shares(t);
      if (scored) {
        for (auto& u : per_view) u.setZero(P + S);
        TexelSystem<Basis, D>(s, t, x[t], true, &Ht, &gt, nullptr, ViewGradients{&per_view});
      } else {
        TexelSystem<Basis, D>(s, t, x[t], true, &Ht, &gt);
      }
      const LocalMatrix A = Ht.topLeftCorner(P, P);
      const Eigen::LDLT<LocalMatrix> ldlt(A);
      LocalMatrix AiB;
      if (S > 0) {
        AiB = ldlt.solve(Ht.topRightCorner(P, S));
        const LocalMatrix red =
            Ht.bottomRightCorner(S, S) - Ht.topRightCorner(P, S).transpose() * AiB;
        const LocalVector gred = gt.tail(S) - AiB.transpose() * gt.head(P);
        SharedIndex(s, t, &map);
        for (int a = 0; a < S && s.Shares(t); ++a) {
          gl(map[a]) += gred(a);
          for (int c = 0; c < S; ++c) Hl(map[a], map[c]) += red(a, c);
        }
        if (scored) {
          for (size_t v = 0; v < views; ++v) {
            const LocalVector reduced = per_view[v].tail(S) - AiB.transpose() * per_view[v].head(P);
            for (int a = 0; a < S; ++a) scores[v](map[a]) += reduced(a);
          }
        }
      }
      if (blocks) {
        Eigen::Map<Eigen::MatrixXd>(blocks->At(t), P, P) = ldlt.solve(LocalMatrix::Identity(P, P));
        if (S > 0) Eigen::Map<Eigen::MatrixXd>(blocks->At(t) + P * P, P, S) = AiB;
      }
    }
    std::lock_guard<std::mutex> lock(mutex);
    *H += Hl;
    *g += gl;
    for (size_t v = 0; v < scores.size(); ++v) (*view_scores)[v] += scores[v];
  });
}

}  // namespace

std::string ToString(RoughnessMode mode) {
  switch (mode) {
    case RoughnessMode::kSample:
      return "one for the sample";
    case RoughnessMode::kClusters:
      return "one per material cluster";
    case RoughnessMode::kTexel:
      return "one per texel";
  }
  return "";
}

Eigen::Vector3d MapsLamp::InBoard(const TexelData& data, size_t v) const {
  switch (frame) {
    case Frame::kBoard:
      return position;
    case Frame::kCamera:
      return data.views[v].board_from_cam * position;
    case Frame::kPerView:
      return per_view.at(v);
  }
  return position;
}

void TexelSolveOptions::Check() const {
  if (!(normal_prior_deg > 0 && normal_prior_deg <= 80)) {
    throw InputError("--normal-prior-deg: must be in (0, 80]");
  }
  if (!(roughness_prior > 0)) throw InputError("maps: the roughness prior must be > 0");
  if (!(huber_k > 0)) throw InputError("maps: the Huber scale must be > 0");
  if (max_texel_iterations < 1 || outer_iterations < 0) {
    throw InputError("maps: iteration counts must be >= 1");
  }
  if (min_views < 1) throw InputError("maps: min_views must be >= 1");
  if (!(shared_step_sd > 0 && shared_step_sd <= 1)) {
    throw InputError("maps: the shared values' step tolerance must be in (0, 1] sd");
  }
}

namespace {

// One FitTexels run: the texels' unknowns and the shared values (roughness per cluster, lamp
// position and intensity) that `s` and `lamp` hold, updated by Gauss-Newton on the system the
// texels reduce to, then their standard deviations and the fit's outputs.
template <typename Basis>
class SharedFit {
 public:
  SharedFit(const TexelData& data, Pass& s, const MapsLamp& lamp, const TexelSolveOptions& o,
            TexelFit* fit)
      : data_(data),
        s_(s),
        o_(o),
        fit_(fit),
        lamp_(lamp),
        n_(data.grid.size()),
        cm_(s.C * s.m),
        K_(s.K()),
        il_(s.lamp_cols ? K_ : -1),
        ii_(s.intensity_col ? K_ + (s.lamp_cols ? 3 : 0) : -1) {}

  // Every masked texel from the start's values where it fitted them, else from a flat sample.
  void Start(const TexelFit* start) {
    x_.assign(n_, State());
    for (size_t t = 0; t < n_; ++t) {
      if (!data_.mask[t]) continue;
      if (start && start->fitted[t]) {
        for (int k = 0; k < cm_; ++k) x_[t].w[k] = start->w[t * cm_ + k];
        x_[t].p = start->p[t];
        x_[t].q = start->q[t];
        x_[t].r = start->r[t];
      } else {
        x_[t] =
            StartState<Basis>(s_, t, s_.info.has_roughness ? s_.cluster_r[(*s_.cluster)[t]] : 0.0);
      }
    }
    cost_ = TexelPass();
  }

  // Gauss-Newton on the shared values, the texels re-solved after each step; done when the
  // step is below a tenth of the shared values' standard deviation as Uncertainty reports it:
  // the model's (H^-1), widened by the views' scatter (ViewScatter) as measured at the first
  // step. The model's alone is up to ten times narrower on a full-size session (the views'
  // registration and exposure errors), and steps of a tenth of it took 12 texel passes of
  // 4-5 s each where the lamp moved 0.1 mm against a reported 3 mm (docs/maps.md "Speed").
  void UpdateShared() {
    Eigen::VectorXd widen;  // per shared value: the views' scatter's widening of its sd
    for (int it = 0; HasShared() && it < o_.outer_iterations; ++it) {
      // A held lamp's columns are left out of the step below: no need of their derivatives.
      std::vector<Eigen::VectorXd> scores;
      Reduced(it == 0 ? &scores : nullptr, nullptr, !s_.lamp_held);
      if (it == 0) widen = SdFactors(scores, PseudoInverse(H_), false);
      Eigen::MatrixXd A = H_;
      Eigen::VectorXd g = g_;
      for (int k = 0; k < A.rows(); ++k) A(k, k) += 1e-9 * A(k, k) + 1e-12;
      if (s_.lamp_held) {  // a step of the others with the lamp where it is
        A.middleRows(il_, 3).setZero();
        A.middleCols(il_, 3).setZero();
        A.block(il_, il_, 3, 3).setIdentity();
        g.segment(il_, 3).setZero();
      }
      const Eigen::VectorXd delta = A.ldlt().solve(-g);
      const Eigen::VectorXd scaled = delta.cwiseQuotient(widen);
      const double tolerance = o_.shared_step_sd * o_.shared_step_sd;
      if (!delta.allFinite() || scaled.dot(H_ * scaled) < tolerance) break;
      // The step's gain as the reduced system predicts it, against what the texel passes can
      // resolve: each texel stops where its own step would gain less than kTolerance, so a
      // shared step worth less than that over the texels moves few of them and the pass's
      // cost cannot confirm it (textured-3mat's final fit: 0.3 predicted against 250, two
      // passes of 2 s each and "no gain"). Such a step is within the texels' convergence of
      // the optimum: taken as Gauss-Newton gives it, unverified, and the steps go on until one
      // is below the tolerance (the bias bootstrap's refits need them: incidental_bias.h).
      const double predicted = -(2 * delta.dot(g_) + delta.dot(H_ * delta));
      const bool resolvable = predicted >= kTolerance * static_cast<double>(SharingTexels());
      const bool moved = resolvable ? TryStep(delta) : TakeStep(delta);
      spdlog::debug("maps: shared step {}: cost {:.6g}, lamp ({:.4f}, {:.4f}, {:.4f}), {}", it,
                    cost_, lamp_.position.x(), lamp_.position.y(), lamp_.position.z(),
                    !resolvable ? "taken below the texels' resolution"
                    : moved     ? "taken"
                                : "no gain");
      if (!moved) break;
    }
  }

  // Standard deviations: the shared covariance from the reduced system, then every texel's.
  void Uncertainty() {
    fit_->sd_w.assign(n_ * cm_, 0.f);
    fit_->sd_normal_deg.assign(n_, 0.f);
    fit_->sd_r.assign(n_, 0.f);
    Eigen::MatrixXd cov;
    std::vector<Eigen::VectorXd> scores;
    TexelBlocks blocks;
    Reduced(HasShared() ? &scores : nullptr, &blocks);
    if (HasShared()) {
      // A shared value in a direction the data do not reach (a cluster whose texels all lie
      // on material edges) has no standard deviation: the pseudo-inverse would give it 0.
      Eigen::VectorXd unreached;
      cov = PseudoInverse(H_, &unreached);
      ViewScatter(scores, &cov);
      fit_->cluster_r_sd.assign(K_, 0.0);
      for (int k = 0; k < K_; ++k) {
        fit_->cluster_r_sd[k] = unreached(k) > 1e-3 ? std::numeric_limits<double>::quiet_NaN()
                                                    : std::sqrt(std::max(0.0, cov(k, k)));
      }
      if (il_ >= 0) {
        lamp_.position_sd = cov.block<3, 3>(il_, il_).diagonal().cwiseMax(0.0).cwiseSqrt();
      }
      if (ii_ >= 0) lamp_.intensity_sd = std::sqrt(std::max(0.0, cov(ii_, ii_)));
    }
    const int P = blocks.P, S = blocks.S;
    ParallelFor(n_, o_.threads, [&](size_t b, size_t e) {
      std::vector<int> map;
      for (size_t t = b; t < e; ++t) {
        if (!fit_->fitted[t]) continue;
        if (S > 0) SharedIndex(s_, t, &map);
        const LocalMatrix AiB =
            S > 0 ? LocalMatrix(Eigen::Map<const Eigen::MatrixXd>(blocks.At(t) + P * P, P, S))
                  : LocalMatrix();
        TexelStandardDeviations(s_, t, x_[t], Eigen::Map<const Eigen::MatrixXd>(blocks.At(t), P, P),
                                AiB, map, HasShared() ? &cov : nullptr, fit_);
      }
    });
  }

  // The maps and shared values (TexelSolveOptions::values_only: nothing else).
  void Values() {
    fit_->w.assign(n_ * cm_, 0.f);
    fit_->p.assign(n_, 0.f);
    fit_->q.assign(n_, 0.f);
    fit_->r.assign(n_, 0.f);
    for (size_t t = 0; t < n_; ++t) {
      if (!fit_->fitted[t]) continue;
      for (int k = 0; k < cm_; ++k) fit_->w[t * cm_ + k] = static_cast<float>(x_[t].w[k]);
      fit_->p[t] = static_cast<float>(x_[t].p);
      fit_->q[t] = static_cast<float>(x_[t].q);
      fit_->r[t] = static_cast<float>(s_.RoughnessOf(t, x_[t]));
    }
    fit_->cluster_r = s_.cluster_r;
    fit_->lamp = lamp_;
  }

  // The maps, chi2 and BIC over the texels that share; the edge texels' standard deviations
  // scaled by their own misfit.
  void Outputs() {
    Values();
    fit_->chi2 = fit_->edge_chi2 = 0;
    fit_->residuals = fit_->edge_residuals = fit_->edge_texels = 0;
    size_t fitted = 0;
    for (size_t t = 0; t < n_; ++t) {
      if (!fit_->fitted[t]) continue;
      size_t nr = 0;
      const double chi2 = TexelCost<Basis>(s_, t, x_[t], &nr);
      if (s_.Shares(t)) {
        ++fitted;
        fit_->chi2 += chi2;
        fit_->residuals += nr;
        continue;
      }
      ++fit_->edge_texels;
      fit_->edge_chi2 += chi2;
      fit_->edge_residuals += nr;
      ScaleEdgeSd(t, chi2, nr);
    }
    fit_->parameters = fitted * s_.P() + s_.GlobalShared();
    fit_->bic =
        fit_->chi2 + static_cast<double>(fit_->parameters) *
                         std::log(std::max<double>(2.0, static_cast<double>(fit_->residuals)));
  }

 private:
  bool HasShared() const { return s_.GlobalShared() > 0; }

  // Every texel solved given the shared values; returns the total robust cost (texels, their
  // priors and the white reference).
  double TexelPass() {
    std::vector<uint8_t> ok(n_, 0);
    std::vector<double> cost(n_, 0.0);
    ParallelFor(n_, o_.threads, [&](size_t b, size_t e) {
      for (size_t t = b; t < e; ++t) {
        if (data_.mask[t]) ok[t] = SolveTexel<Basis>(s_, t, &x_[t], &cost[t]);
      }
    });
    fit_->fitted = std::move(ok);
    double total = 0;
    for (size_t t = 0; t < n_; ++t) total += fit_->fitted[t] && s_.Shares(t) ? cost[t] : 0.0;
    Eigen::MatrixXd Hw = Eigen::MatrixXd::Zero(s_.GlobalShared() + 4, s_.GlobalShared() + 4);
    Eigen::VectorXd gw = Eigen::VectorXd::Zero(s_.GlobalShared() + 4);
    return total + WhiteSystem(s_, lamp_, -1, -1, &Hw, &gw);
  }

  // The shared values' covariance `cov` (from the reduced system: every residual independent)
  // widened where the views' scatter says more. A view's errors are not independent over its
  // texels: its pose, its exposure and the calibration at its pixels move all of them together,
  // and the shared values (one roughness from every texel) do not average those out. The
  // cluster-robust covariance with the views as clusters, H^-1 (V / (V - 1) sum_v psi_v psi_v' +
  // H_white) H^-1 (psi_v: view v's part of the reduced gradient, the white reference's residuals
  // counted as independent), measures them; each shared value's variance becomes the larger of
  // the two, its correlations kept (cov -> D cov D, D diagonal, >= 1). fit_->shared_sd_factor
  // holds D. docs/maps.md "Standard deviations".
  void ViewScatter(const std::vector<Eigen::VectorXd>& scores, Eigen::MatrixXd* cov) {
    const Eigen::VectorXd d = SdFactors(scores, *cov, true);
    fit_->shared_sd_factor.assign(d.data(), d.data() + d.size());
    *cov = d.asDiagonal() * (*cov) * d.asDiagonal();
  }

  // Per shared value, the factor (>= 1) by which the views' scatter widens its standard
  // deviation under `cov` (ViewScatter); all 1 with fewer than two views.
  Eigen::VectorXd SdFactors(const std::vector<Eigen::VectorXd>& scores, const Eigen::MatrixXd& cov,
                            bool log) {
    const int G = static_cast<int>(cov.rows());
    Eigen::VectorXd factor = Eigen::VectorXd::Ones(G);
    Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(G, G);
    Eigen::VectorXd gw = Eigen::VectorXd::Zero(G);
    WhiteSystem(s_, lamp_, il_, ii_, &meat, &gw);
    int views = 0;
    Eigen::MatrixXd outer = Eigen::MatrixXd::Zero(G, G);
    for (const auto& psi : scores) {
      if (psi.squaredNorm() == 0) continue;
      outer += psi * psi.transpose();
      ++views;
    }
    if (views < 2) return factor;
    meat += outer * (static_cast<double>(views) / (views - 1));
    const Eigen::MatrixXd robust = cov * meat * cov;
    for (int k = 0; k < G; ++k) {
      if (log) {
        spdlog::debug("maps: shared value {}: sd {:.4g}, from the views' scatter {:.4g} ({} views)",
                      k, std::sqrt(cov(k, k)), std::sqrt(robust(k, k)), views);
      }
      if (cov(k, k) > 0 && robust(k, k) > cov(k, k))
        factor(k) = std::sqrt(robust(k, k) / cov(k, k));
    }
    return factor;
  }

  // The pseudo-inverse of the symmetric `H`: directions below 1e-12 of its largest eigenvalue
  // get no variance; with `unreached`, per value the share of it in those directions.
  static Eigen::MatrixXd PseudoInverse(const Eigen::MatrixXd& H,
                                       Eigen::VectorXd* unreached = nullptr) {
    const Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> eig(H);
    Eigen::VectorXd inv = eig.eigenvalues();
    if (unreached) unreached->setZero(inv.size());
    for (int k = 0; k < inv.size(); ++k) {
      const bool reached = inv(k) > 1e-12 * eig.eigenvalues().maxCoeff();
      inv(k) = reached ? 1.0 / inv(k) : 0.0;
      if (!reached && unreached) *unreached += eig.eigenvectors().col(k).cwiseAbs2();
    }
    return eig.eigenvectors() * inv.asDiagonal() * eig.eigenvectors().transpose();
  }

  // The reduced shared system into H_ and g_ (ReducedSystem), each view's reduced gradient
  // with `scores`, the texels' blocks with `blocks`; the lamp's columns are zero without
  // `lamp_derivatives` (Jets of 3 dimensions instead of 6).
  void Reduced(std::vector<Eigen::VectorXd>* scores, TexelBlocks* blocks,
               bool lamp_derivatives = true) {
    if (s_.lamp_cols && lamp_derivatives) {
      ReducedSystem<Basis, 6>(s_, x_, *fit_, &H_, &g_, scores, blocks);
    } else {
      ReducedSystem<Basis, 3>(s_, x_, *fit_, &H_, &g_, scores, blocks);
    }
    WhiteSystem(s_, lamp_, il_, ii_, &H_, &g_);
  }

  size_t SharingTexels() const {
    size_t n = 0;
    for (size_t t = 0; t < n_; ++t) n += fit_->fitted[t] && s_.Shares(t);
    return n;
  }

  // The shared values `step` x `delta` from `r_old` and `lamp_old`, the texels solved again
  // from where they are; returns the pass's cost.
  double MoveShared(const std::vector<double>& r_old, const MapsLamp& lamp_old,
                    const Eigen::VectorXd& delta, double step) {
    for (int k = 0; k < K_; ++k) {
      s_.cluster_r[k] =
          std::clamp(r_old[k] + step * delta(k), s_.info.roughness_lo, s_.info.roughness_hi);
    }
    if (il_ >= 0) lamp_.position = lamp_old.position + step * delta.segment<3>(il_);
    if (ii_ >= 0) lamp_.intensity = std::max(1e-12, lamp_old.intensity + step * delta(ii_));
    SetLamp(data_, lamp_, &s_);
    ++fit_->outer_iterations;
    return TexelPass();
  }

  // The whole step, unverified (UpdateShared: below the texels' resolution).
  bool TakeStep(const Eigen::VectorXd& delta) {
    // Copies: MoveShared writes the values it steps from.
    cost_ = MoveShared(std::vector<double>(s_.cluster_r), MapsLamp(lamp_), delta, 1.0);
    return true;
  }

  // The shared values moved by `delta`, or a quarter of it when the whole step does not lower
  // the cost; false (the old values and texels kept) when neither does.
  bool TryStep(const Eigen::VectorXd& delta) {
    const std::vector<double> r_old = s_.cluster_r;
    const MapsLamp lamp_old = lamp_;
    const std::vector<State> x_old = x_;
    const std::vector<uint8_t> fitted_old = fit_->fitted;
    for (double step : {1.0, 0.25}) {
      x_ = x_old;
      const double c = MoveShared(r_old, lamp_old, delta, step);
      if (c <= cost_) {
        cost_ = c;
        return true;
      }
    }
    // No gain along the step: the old shared values and the texels solved for them (no pass
    // again: it took a whole texel pass, 5-7 s at 512 x 512).
    s_.cluster_r = r_old;
    lamp_ = lamp_old;
    SetLamp(data_, lamp_, &s_);
    x_ = x_old;
    fit_->fitted = fitted_old;
    return false;
  }

  // A texel whose samples mix two materials is not described by one material's model: its
  // misfit, not its noise, bounds what it measures, so its standard deviations carry it.
  void ScaleEdgeSd(size_t t, double chi2, size_t nr) {
    const double birge =
        std::sqrt(std::max(1.0, chi2 / std::max(1.0, static_cast<double>(nr) - s_.P())));
    for (int k = 0; k < cm_; ++k) fit_->sd_w[t * cm_ + k] *= static_cast<float>(birge);
    fit_->sd_normal_deg[t] *= static_cast<float>(birge);
    fit_->sd_r[t] *= static_cast<float>(birge);
  }

  const TexelData& data_;
  Pass& s_;
  const TexelSolveOptions& o_;
  TexelFit* fit_;
  MapsLamp lamp_;
  const size_t n_;
  const int cm_, K_, il_, ii_;
  std::vector<State> x_;
  double cost_ = 0;
  Eigen::MatrixXd H_;
  Eigen::VectorXd g_;
};

template <typename Basis>
void RunFit(const TexelData& data, Pass& s, const TexelFit* start, const MapsLamp& lamp,
            const TexelSolveOptions& o, TexelFit* fit) {
  SharedFit<Basis> f(data, s, lamp, o, fit);
  f.Start(start);
  if (o.values_only) return f.Values();
  f.UpdateShared();
  f.Uncertainty();
  f.Outputs();
}

}  // namespace

TexelFit FitTexels(const TexelData& data, RoughnessMode mode, const std::vector<int>& clusters,
                   int k, const MapsLamp& lamp, const NoiseModel& noise, const TexelFit* start,
                   const TexelSolveOptions& o, const TexelEdges& edges) {
  o.Check();
  const auto t0 = std::chrono::steady_clock::now();
  TexelFit fit;
  fit.mode = mode;
  fit.model = o.model;
  fit.noise = noise;
  Pass s;
  s.data = &data;
  s.options = &o;
  s.info = InfoOf(o.model);
  s.mode = s.info.has_roughness ? mode : RoughnessMode::kSample;
  fit.mode = s.mode;
  s.C = data.channels;
  s.m = s.info.channel_params;
  fit.channels = s.C;
  fit.m = s.m;
  s.noise = noise;
  s.inv_slope_var = 1.0 / std::pow(std::tan(DegToRad(o.normal_prior_deg)), 2);
  s.inv_r_var = 1.0 / (o.roughness_prior * o.roughness_prior);
  std::vector<int> one(data.grid.size(), 0);
  const bool use_clusters = mode != RoughnessMode::kSample && k > 0 && !clusters.empty();
  s.cluster = use_clusters ? &clusters : &one;
  fit.clusters = use_clusters ? k : 1;
  fit.cluster = *s.cluster;
  fit.edges = edges;
  s.edges = &fit.edges;
  const int n_r = fit.clusters;
  s.cluster_r.assign(n_r, s.info.roughness_start);
  if (start && static_cast<int>(start->cluster_r.size()) == n_r &&
      (mode != RoughnessMode::kTexel || n_r == 1)) {
    s.cluster_r = start->cluster_r;  // the start's own shared values
  } else if (start && !start->cluster_r.empty()) {
    // Each cluster starts from the mean of the start's roughness over its texels.
    std::vector<double> sum(n_r, 0.0), cnt(n_r, 0.0);
    for (size_t t = 0; t < data.grid.size(); ++t) {
      if (!start->fitted[t]) continue;
      sum[(*s.cluster)[t]] += start->r[t];
      cnt[(*s.cluster)[t]] += 1;
    }
    for (int c = 0; c < n_r; ++c) {
      if (cnt[c] > 0) s.cluster_r[c] = sum[c] / cnt[c];
    }
  }
  s.lamp_cols =
      (lamp.refine_position || lamp.position_fitted) && lamp.frame != MapsLamp::Frame::kPerView;
  s.lamp_held = s.lamp_cols && !lamp.refine_position;
  s.intensity_col = lamp.white_albedo.has_value() && !data.white.empty();
  SetLamp(data, lamp, &s);
  VisitMapsModel(o.model, [&](auto basis) {
    using Basis = decltype(basis);
    RunFit<Basis>(data, s, start, lamp, o, &fit);
  });
  for (size_t t = 0; t < data.grid.size(); ++t) {
    if (!fit.fitted[t]) fit.cluster[t] = -1;
  }
  fit.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return fit;
}

}  // namespace gonio
