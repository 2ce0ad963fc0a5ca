#include "estimation/maps/texel_system.h"

#include <cmath>

namespace gonio::texel_internal {

// The lamp's board position per view and its derivative with respect to the lamp's
// parameters.
void SetLamp(const TexelData& data, const MapsLamp& lamp, Pass* s) {
  s->lamp.resize(data.views.size());
  s->lamp_d.resize(data.views.size());
  for (size_t v = 0; v < data.views.size(); ++v) {
    s->lamp[v] = lamp.InBoard(data, v);
    s->lamp_d[v] = lamp.frame == MapsLamp::Frame::kBoard    ? Eigen::Matrix3d::Identity()
                   : lamp.frame == MapsLamp::Frame::kCamera ? data.views[v].board_from_cam.R
                                                            : Eigen::Matrix3d::Zero();
  }
  s->intensity = lamp.intensity;
}

// The white reference's contribution to the shared system (lamp and intensity columns at
// `il` and `ii` of the global system, -1 when not fitted), and its cost.
double WhiteSystem(const Pass& s, const MapsLamp& lamp, int il, int ii, Eigen::MatrixXd* H,
                   Eigen::VectorXd* g) {
  using J = ceres::Jet<double, 3>;
  if (!lamp.white_albedo) return 0.0;
  const double albedo = *lamp.white_albedo * kInvPi;
  const Eigen::Vector3d n(0, 0, -1);
  double cost = 0;
  for (const WhiteSample& w : s.data->white) {
    Vec3<J> L = s.lamp[w.view].cast<J>();
    for (int a = 0; a < 3; ++a) {
      for (int b = 0; b < 3; ++b) L[a].v[b] = s.lamp_d[w.view](a, b);
    }
    const Vec3<J> to_lamp = L - w.p_in_board.cast<J>();
    const J d2 = to_lamp.squaredNorm();
    const J ci = to_lamp.dot(n.cast<J>()) / sqrt(d2);
    if (!(ci > J(kMinCos))) continue;
    const J pred = s.intensity * albedo * ci / d2;
    for (int c = 0; c < s.C; ++c) {
      const double var = s.noise.Variance(c, w.var_read[c], w.var_shot[c], w.radiance[c]);
      if (!(var > 0)) continue;
      const double inv_sigma = 1 / std::sqrt(var);
      const double z = (pred.a - w.radiance[c]) * inv_sigma;
      double weight;
      cost += Huber(z, s.options->huber_k, &weight);
      double row[4];
      int idx[4], nz = 0;
      if (il >= 0) {
        for (int a = 0; a < 3; ++a) idx[nz] = il + a, row[nz++] = pred.v[a] * inv_sigma;
      }
      if (ii >= 0) idx[nz] = ii, row[nz++] = pred.a / s.intensity * inv_sigma;
      for (int a = 0; a < nz; ++a) {
        (*g)(idx[a]) += weight * row[a] * z;
        for (int b = 0; b < nz; ++b) (*H)(idx[a], idx[b]) += weight * row[a] * row[b];
      }
    }
  }
  return cost;
}

// The local -> global index of texel t's shared columns.
void SharedIndex(const Pass& s, size_t t, std::vector<int>* out) {
  out->clear();
  if (s.shared_r()) out->push_back((*s.cluster)[t]);
  const int K = s.K();
  if (s.lamp_cols) {
    for (int a = 0; a < 3; ++a) out->push_back(K + a);
  }
  if (s.intensity_col) out->push_back(K + (s.lamp_cols ? 3 : 0));
}

// The pass of a finished fit (its mode, clusters, lamp and noise), without shared columns.
Pass PassOf(const TexelData& data, const TexelFit& fit, const TexelSolveOptions& o) {
  Pass s;
  s.data = &data;
  s.options = &o;
  s.info = InfoOf(fit.model);
  s.mode = fit.mode;
  s.C = fit.channels;
  s.m = fit.m;
  s.noise = fit.noise;
  s.inv_slope_var = 1.0 / std::pow(std::tan(DegToRad(o.normal_prior_deg)), 2);
  s.inv_r_var = 1.0 / (o.roughness_prior * o.roughness_prior);
  s.cluster = &fit.cluster;
  s.edges = &fit.edges;
  s.cluster_r = fit.cluster_r;
  SetLamp(data, fit.lamp, &s);
  return s;
}

State StateOf(const TexelFit& fit, size_t t) {
  State x;
  const int cm = fit.channels * fit.m;
  for (int k = 0; k < cm; ++k) x.w[k] = fit.w[t * cm + k];
  x.p = fit.p[t];
  x.q = fit.q[t];
  x.r = fit.r[t];
  return x;
}

}  // namespace gonio::texel_internal
