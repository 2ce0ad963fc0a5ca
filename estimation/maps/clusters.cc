#include "estimation/maps/clusters.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <opencv2/imgproc.hpp>

#include "common/error.h"
#include "common/math.h"
#include "common/stats.h"

namespace gonio {
namespace {

struct Mixture {
  std::vector<double> weight;
  std::vector<Eigen::VectorXd> mean;
  std::vector<Eigen::MatrixXd> cov;
  double log_likelihood = -INFINITY;
};

// log N(x; mean, cov) for every row and component, from the Cholesky factors.
Eigen::MatrixXd LogDensities(const Eigen::MatrixXd& X, const Mixture& m) {
  const int d = static_cast<int>(X.cols()), k = static_cast<int>(m.mean.size());
  Eigen::MatrixXd out(X.rows(), k);
  for (int c = 0; c < k; ++c) {
    const Eigen::LLT<Eigen::MatrixXd> llt(m.cov[c]);
    const Eigen::MatrixXd L = llt.matrixL();
    const double log_det = 2 * L.diagonal().array().log().sum();
    const Eigen::MatrixXd centred = (X.rowwise() - m.mean[c].transpose()).transpose();
    const Eigen::MatrixXd y = L.triangularView<Eigen::Lower>().solve(centred);
    out.col(c) = (-0.5 * (y.colwise().squaredNorm().array() + log_det + d * std::log(2 * kPi)))
                     .matrix()
                     .transpose();
  }
  return out;
}

// Responsibilities (rows sum to 1) and the total log-likelihood.
double EStep(const Eigen::MatrixXd& X, const Mixture& m, Eigen::MatrixXd* resp) {
  Eigen::MatrixXd logp = LogDensities(X, m);
  for (size_t c = 0; c < m.weight.size(); ++c) logp.col(c).array() += std::log(m.weight[c]);
  double ll = 0;
  resp->resize(X.rows(), m.weight.size());
  for (int i = 0; i < X.rows(); ++i) {
    const double mx = logp.row(i).maxCoeff();
    const double s = (logp.row(i).array() - mx).exp().sum();
    ll += mx + std::log(s);
    resp->row(i) = (logp.row(i).array() - mx - std::log(s)).exp();
  }
  return ll;
}

void MStep(const Eigen::MatrixXd& X, const Eigen::MatrixXd& resp, Mixture* m) {
  const int d = static_cast<int>(X.cols());
  for (int c = 0; c < resp.cols(); ++c) {
    const double nk = std::max(resp.col(c).sum(), 1e-9);
    m->weight[c] = nk / X.rows();
    m->mean[c] = (X.transpose() * resp.col(c)) / nk;
    const Eigen::MatrixXd centred = X.rowwise() - m->mean[c].transpose();
    m->cov[c] = (centred.transpose() * resp.col(c).asDiagonal() * centred) / nk +
                1e-4 * Eigen::MatrixXd::Identity(d, d);  // features are standardised
  }
}

// k-means++ seeds, a few Lloyd steps, then EM.
Mixture FitMixture(const Eigen::MatrixXd& X, int k, const ClusterOptions& o) {
  std::mt19937_64 rng(o.seed + 977 * k);
  const int n = static_cast<int>(X.rows()), d = static_cast<int>(X.cols());
  std::vector<Eigen::VectorXd> centre = {X.row(std::uniform_int_distribution<int>(0, n - 1)(rng))};
  std::vector<double> d2(n);
  while (static_cast<int>(centre.size()) < k) {
    for (int i = 0; i < n; ++i) {
      d2[i] = INFINITY;
      for (const auto& c : centre)
        d2[i] = std::min(d2[i], (X.row(i).transpose() - c).squaredNorm());
    }
    std::discrete_distribution<int> pick(d2.begin(), d2.end());
    centre.push_back(X.row(pick(rng)));
  }
  Eigen::MatrixXd resp = Eigen::MatrixXd::Zero(n, k);
  for (int it = 0; it < 10; ++it) {
    resp.setZero();
    for (int i = 0; i < n; ++i) {
      int best = 0;
      for (int c = 1; c < k; ++c) {
        if ((X.row(i).transpose() - centre[c]).squaredNorm() <
            (X.row(i).transpose() - centre[best]).squaredNorm()) {
          best = c;
        }
      }
      resp(i, best) = 1;
    }
    for (int c = 0; c < k; ++c) {
      const double nk = resp.col(c).sum();
      if (nk > 0) centre[c] = X.transpose() * resp.col(c) / nk;
    }
  }
  Mixture m;
  m.weight.assign(k, 1.0 / k);
  m.mean.assign(k, Eigen::VectorXd::Zero(d));
  m.cov.assign(k, Eigen::MatrixXd::Identity(d, d));
  MStep(X, resp, &m);
  for (int it = 0; it < o.em_iterations; ++it) {
    const double ll = EStep(X, m, &resp);
    MStep(X, resp, &m);
    const bool done = std::abs(ll - m.log_likelihood) < 1e-6 * std::abs(ll);
    m.log_likelihood = ll;
    if (done) break;
  }
  m.log_likelihood = EStep(X, m, &resp);
  return m;
}

}  // namespace

std::vector<int> ClusterResult::Assign(const Eigen::MatrixXd& features) const {
  std::vector<int> out(features.rows(), 0);
  if (mix_weight.empty() || features.rows() == 0) return out;
  const Eigen::MatrixXd Z = (features.rowwise() - mu).array().rowwise() / sd.array();
  Mixture m;
  m.weight = mix_weight;
  m.mean = mix_mean;
  m.cov = mix_cov;
  Eigen::MatrixXd resp;
  EStep(Z, m, &resp);
  for (int i = 0; i < Z.rows(); ++i) {
    Eigen::Index c;
    resp.row(i).maxCoeff(&c);
    out[i] = component_cluster[c];
  }
  return out;
}

void ClusterOptions::Check() const {
  if (max_k < 1 || max_k > 12) throw InputError("--max-clusters: must be in [1, 12]");
  if (!(min_weight >= 0 && min_weight < 0.5))
    throw InputError("maps: min cluster weight in [0, 0.5)");
  if (max_samples < 100) throw InputError("maps: cluster subsample must be >= 100");
}

ClusterResult ClusterByBic(const Eigen::MatrixXd& features, const ClusterOptions& o) {
  o.Check();
  const int n = static_cast<int>(features.rows()), d = static_cast<int>(features.cols());
  ClusterResult result;
  result.label.assign(n, 0);
  if (n < 10 * (d + d * (d + 1) / 2)) {
    result.component_cluster = {0};
    result.weight = {1.0};
    result.mean = {n > 0 ? Eigen::VectorXd(features.colwise().mean().transpose())
                         : Eigen::VectorXd::Zero(d)};
    return result;
  }
  // Standardised features, an even subsample for EM.
  const Eigen::RowVectorXd mu = features.colwise().mean();
  Eigen::RowVectorXd sd = ((features.rowwise() - mu).array().square().colwise().sum() / n).sqrt();
  for (int j = 0; j < d; ++j) sd(j) = sd(j) > 0 ? sd(j) : 1.0;
  const Eigen::MatrixXd Z = (features.rowwise() - mu).array().rowwise() / sd.array();
  const int stride = std::max(1, static_cast<int>((n + o.max_samples - 1) / o.max_samples));
  Eigen::MatrixXd S((n + stride - 1) / stride, d);
  for (int i = 0, j = 0; i < n; i += stride, ++j) S.row(j) = Z.row(i);
  const double p_per = d + d * (d + 1) / 2.0;
  double best_bic = INFINITY;
  Mixture best;
  for (int k = 1; k <= o.max_k; ++k) {
    const Mixture m = FitMixture(S, k, o);
    const double p = k * p_per + (k - 1);
    const double bic = -2 * m.log_likelihood + p * std::log(static_cast<double>(S.rows()));
    const bool small = *std::min_element(m.weight.begin(), m.weight.end()) < o.min_weight;
    result.bic.push_back(small ? std::numeric_limits<double>::quiet_NaN() : bic);
    if (!small && bic < best_bic) {
      best_bic = bic;
      best = m;
    }
  }
  // Label every texel; clusters ordered by weight (largest first).
  const int k = static_cast<int>(best.weight.size());
  std::vector<int> order(k);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return best.weight[a] > best.weight[b]; });
  std::vector<int> rank(k);
  for (int i = 0; i < k; ++i) rank[order[i]] = i;
  result.mu = mu;
  result.sd = sd;
  result.mix_weight = best.weight;
  result.mix_mean = best.mean;
  result.mix_cov = best.cov;
  result.component_cluster = rank;
  result.label = result.Assign(features);
  result.k = result.mixture_k = k;
  result.weight.assign(k, 0.0);
  result.mean.assign(k, Eigen::VectorXd::Zero(d));
  for (int i = 0; i < n; ++i) {
    result.weight[result.label[i]] += 1.0 / n;
    result.mean[result.label[i]] += features.row(i).transpose();
  }
  for (int c = 0; c < k; ++c) {
    if (result.weight[c] > 0) result.mean[c] /= result.weight[c] * n;
  }
  return result;
}

namespace {

// Cluster b merged into a, labels renumbered 0..k-2 by weight (largest first), weights, means
// and the components' clusters to match.
void MergeInto(int a_keep, int b_gone, const Eigen::MatrixXd& features, ClusterResult* c) {
  const int n = static_cast<int>(features.rows()), d = static_cast<int>(features.cols());
  const int k = c->k;
  std::vector<double> weight(k, 0.0);
  std::vector<Eigen::VectorXd> sum(k, Eigen::VectorXd::Zero(d));
  for (int i = 0; i < n; ++i) {
    if (c->label[i] == b_gone) c->label[i] = a_keep;
  }
  for (int i = 0; i < n; ++i) {
    weight[c->label[i]] += 1.0 / n;
    sum[c->label[i]] += features.row(i).transpose();
  }
  std::vector<int> order;
  for (int a = 0; a < k; ++a) {
    if (weight[a] > 0) order.push_back(a);
  }
  std::sort(order.begin(), order.end(), [&](int a, int b) { return weight[a] > weight[b]; });
  std::vector<int> rank(k, -1);
  for (size_t i = 0; i < order.size(); ++i) rank[order[i]] = static_cast<int>(i);
  for (int i = 0; i < n; ++i) c->label[i] = rank[c->label[i]];
  for (int& cl : c->component_cluster) cl = rank[cl == b_gone ? a_keep : cl];
  c->k = static_cast<int>(order.size());
  c->weight.clear();
  c->mean.clear();
  for (int a : order) {
    c->weight.push_back(weight[a]);
    c->mean.push_back(sum[a] / (weight[a] * n));
  }
  c->merged += 1;
}

}  // namespace

void MergeContinuousClusters(const Eigen::MatrixXd& features,
                             const std::vector<size_t>& texel_of_row, int width, int height,
                             double jump_ratio, ClusterResult* c) {
  const int n = static_cast<int>(features.rows()), d = static_cast<int>(features.cols());
  if (c->k < 2 || n == 0) return;
  const Eigen::RowVectorXd mu = features.colwise().mean();
  Eigen::RowVectorXd sd = ((features.rowwise() - mu).array().square().colwise().sum() / n).sqrt();
  for (int j = 0; j < d; ++j) sd(j) = sd(j) > 0 ? sd(j) : 1.0;
  std::vector<int> row_of(static_cast<size_t>(width) * height, -1);
  for (int i = 0; i < n; ++i) row_of[texel_of_row[i]] = i;
  for (;;) {
    const int k = c->k;
    // Neighbour distances inside each cluster (pooled) and across each pair's boundary.
    std::vector<double> inside;
    std::vector<std::vector<std::vector<double>>> across(k, std::vector<std::vector<double>>(k));
    for (int i = 0; i < n; ++i) {
      const size_t t = texel_of_row[i];
      const int x = static_cast<int>(t % width), y = static_cast<int>(t / width);
      for (const auto& [nx, ny] : {std::pair<int, int>{x + 1, y}, {x, y + 1}}) {
        if (nx >= width || ny >= height) continue;
        const int j = row_of[static_cast<size_t>(ny) * width + nx];
        if (j < 0) continue;
        const double dist =
            ((features.row(i) - features.row(j)).array() / sd.array()).matrix().norm();
        const int a = c->label[i], b = c->label[j];
        if (a == b) {
          inside.push_back(dist);
        } else {
          across[std::min(a, b)][std::max(a, b)].push_back(dist);
        }
      }
    }
    const double within = std::max(inside.empty() ? 0.0 : Median(inside), 1e-12);
    int best_a = -1, best_b = -1;
    double best_ratio = jump_ratio;
    for (int a = 0; a < k; ++a) {
      for (int b = a + 1; b < k; ++b) {
        // A boundary of a few texel pairs says nothing: at least 10.
        if (across[a][b].size() < 10) continue;
        const double ratio = Median(across[a][b]) / within;
        if (ratio < best_ratio) {
          best_ratio = ratio;
          best_a = a;
          best_b = b;
        }
      }
    }
    if (best_a < 0) return;
    MergeInto(best_a, best_b, features, c);
  }
}

std::array<int, 2> AlikeClusters(const std::vector<double>& roughness,
                                 const std::vector<double>& sd, size_t residuals) {
  std::array<int, 2> best = {-1, -1};
  double best_z2 = std::log(static_cast<double>(std::max<size_t>(residuals, 2)));
  const int k = static_cast<int>(std::min(roughness.size(), sd.size()));
  for (int a = 0; a < k; ++a) {
    for (int b = a + 1; b < k; ++b) {
      const double d = roughness[a] - roughness[b];
      if (!std::isfinite(d)) continue;
      // Unreached: ranked by the distance alone, below every reached pair.
      const bool unreached = std::isnan(sd[a]) || std::isnan(sd[b]);
      const double var = sd[a] * sd[a] + sd[b] * sd[b];
      if (!unreached && !(var > 0)) continue;
      const double z2 = unreached ? -1.0 / (1.0 + d * d) : d * d / var;
      if (z2 < best_z2) {
        best_z2 = z2;
        best = {a, b};
      }
    }
  }
  return best;
}

void JoinClusters(int keep, int gone, ClusterResult* c, std::vector<int>* texel_label,
                  bool drop_components) {
  if (keep == gone || keep < 0 || gone < 0 || keep >= c->k || gone >= c->k) {
    throw std::invalid_argument("JoinClusters: clusters out of range");
  }
  const size_t others = std::count_if(c->component_cluster.begin(), c->component_cluster.end(),
                                      [&](int x) { return x != gone; });
  if (drop_components && others > 0 && c->mix_weight.size() == c->component_cluster.size()) {
    double left = 0;
    for (size_t j = c->component_cluster.size(); j-- > 0;) {
      if (c->component_cluster[j] != gone) {
        left += c->mix_weight[j];
        continue;
      }
      c->component_cluster.erase(c->component_cluster.begin() + j);
      c->mix_weight.erase(c->mix_weight.begin() + j);
      c->mix_mean.erase(c->mix_mean.begin() + j);
      c->mix_cov.erase(c->mix_cov.begin() + j);
    }
    for (double& w : c->mix_weight) w /= left;
  }
  const auto renumber = [&](int x) {
    if (x == gone) x = keep;
    return x > gone ? x - 1 : x;
  };
  for (int& l : c->label) l = renumber(l);
  for (int& l : c->component_cluster) l = renumber(l);
  if (texel_label) {
    for (int& l : *texel_label) l = l < 0 ? l : renumber(l);
  }
  if (static_cast<int>(c->weight.size()) == c->k && static_cast<int>(c->mean.size()) == c->k) {
    const double w = c->weight[keep] + c->weight[gone];
    if (w > 0) {
      c->mean[keep] = (c->weight[keep] * c->mean[keep] + c->weight[gone] * c->mean[gone]) / w;
    }
    c->weight[keep] = w;
    c->weight.erase(c->weight.begin() + gone);
    c->mean.erase(c->mean.begin() + gone);
  }
  c->k -= 1;
  c->joined += 1;
}

namespace {

// The offset from texel (x, y) to the nearest texel of another cluster within `radius` (the
// exact distance from the transform); +inf where none is found.
Eigen::Vector2f NearestOther(const std::vector<int>& label, int width, int height, int x, int y,
                             int radius) {
  const int own = label[static_cast<size_t>(y) * width + x];
  Eigen::Vector2f best = Eigen::Vector2f::Constant(std::numeric_limits<float>::infinity());
  int best_d2 = std::numeric_limits<int>::max();
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const int xx = x + dx, yy = y + dy, d2 = dx * dx + dy * dy;
      if (xx < 0 || yy < 0 || xx >= width || yy >= height || d2 >= best_d2) continue;
      const int other = label[static_cast<size_t>(yy) * width + xx];
      if (other < 0 || other == own) continue;
      best_d2 = d2;
      best = Eigen::Vector2f(static_cast<float>(dx), static_cast<float>(dy));
    }
  }
  return best;
}

}  // namespace

std::vector<Eigen::Vector2f> MaterialEdgeOffsets(const std::vector<int>& label, int width,
                                                 int height, double max_texels) {
  if (label.size() != static_cast<size_t>(width) * height) {
    throw std::invalid_argument("MaterialEdgeOffsets: labels do not fill the grid");
  }
  std::vector<Eigen::Vector2f> offset(
      label.size(), Eigen::Vector2f::Constant(std::numeric_limits<float>::infinity()));
  const int k = label.empty() ? 0 : *std::max_element(label.begin(), label.end()) + 1;
  cv::Mat other(height, width, CV_8U), to_other;
  for (int own = 0; own < k; ++own) {
    // distanceTransform measures to the nearest zero: the texels of the other clusters. Only the
    // texels it finds within reach are searched for the direction.
    bool any = false;
    for (size_t t = 0; t < label.size(); ++t) {
      const bool is_other = label[t] >= 0 && label[t] != own;
      other.data[t] = is_other ? 0 : 1;
      any = any || is_other;
    }
    if (!any) continue;
    cv::distanceTransform(other, to_other, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
    const float* d = to_other.ptr<float>();
    for (size_t t = 0; t < label.size(); ++t) {
      if (label[t] != own || !(d[t] <= max_texels)) continue;
      const int x = static_cast<int>(t % width), y = static_cast<int>(t / width);
      offset[t] = NearestOther(label, width, height, x, y, static_cast<int>(std::ceil(d[t])));
    }
  }
  return offset;
}

}  // namespace gonio
