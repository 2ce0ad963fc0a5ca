// Model stability sweeps: every registered model towards the horizon and towards (and past) the
// bounds of each parameter, classified against its most exact reference.
#include <algorithm>
#include <cmath>
#include <map>
#include <sstream>

#include "bench/bench_internal.h"
#include "bench/bench_lib.h"
#include "common/error.h"
#include "common/log.h"
#include "common/math.h"
#include "reflectance/registry.h"

namespace gonio::bench {
namespace {

std::string Fmt(double v) {
  std::ostringstream o;
  o << v;
  return o.str();
}

// Evaluates `model` at `params` on `geoms` through the checked API and classifies the point:
// error = CheckParams / EvaluateChecked gave a reason; degraded = finite but farther than
// kDegradedTolerance (albedo/pi) from the reference; valid otherwise.
StabilityCell Classify(const ModelInfo& info, const std::string& ref,
                       const std::vector<double>& params, const std::vector<Angles<double>>& geoms,
                       StabilityReport* rep) {
  StabilityCell c;
  c.subject = info.name;
  c.method = info.method;
  c.status = "valid";
  try {
    CheckParams(info, params);
  } catch (const InputError& e) {
    c.status = "error";
    c.detail = e.what();
    return c;
  }
  const double unit = ErrorUnit(info, params);
  const std::vector<double> ref_params = ref.empty() ? params : MapParams(info.name, params, ref);
  double max_err = 0;
  int compared = 0;
  for (const auto& a : geoms) {
    // The raw formula, as EvaluateBatch would give it: counted, never reported as a value.
    double raw = 0;
    EvaluateBatch(info.name, params, &a.theta_i, &a.theta_r, &a.phi, 1, &raw, 1);
    if (!std::isfinite(raw)) ++rep->raw_nonfinite;
    double v = 0;
    const std::string why = EvaluateChecked(info.name, params, a, &v);
    if (!why.empty()) {
      c.status = "error";
      c.detail = why;
      return c;
    }
    if (!std::isfinite(v)) ++rep->nonfinite_escaped;
    // Finite is not enough: a divergent term evaluated at its pole (tan(pi/2) ~ 1.6e16) or a
    // negative BRDF is no valid value either, reference or not.
    if (v < 0 || v / unit > kImplausibleMagnitude) {
      c.status = "degraded";
      c.detail = "implausible value " + Fmt(v) + " 1/sr at theta_i=" + Fmt(RadToDeg(a.theta_i)) +
                 " theta_r=" + Fmt(RadToDeg(a.theta_r)) + " phi=" + Fmt(RadToDeg(a.phi)) + " deg";
      return c;
    }
    double r = 0;
    if (!ref.empty() && EvaluateAny(ref, ref_params, a, &r).empty()) {
      max_err = std::max(max_err, std::abs(v - r) / unit);
      ++compared;
    }
  }
  if (ref.empty()) {
    c.detail = "finite; no reference";
  } else if (compared == 0) {
    c.detail = "finite; reference " + ref + " undefined here";
  } else {
    c.detail = "max err vs " + ref + " = " + Fmt(max_err) + " albedo/pi";
    if (max_err > kDegradedTolerance) c.status = "degraded";
  }
  return c;
}

}  // namespace

StabilityReport RunModelStability(const BenchSizes& s) {
  StabilityReport rep;
  Progress progress("model stability", RegisteredModels().size());
  // Geometries for parameter sweeps: normal, moderate back and forward scatter, grazing.
  const std::vector<Angles<double>> param_geoms = {{0.0, 0.0, 0.0},
                                                   {DegToRad(30), DegToRad(60), 0.0},
                                                   {DegToRad(60), DegToRad(30), kPi},
                                                   {DegToRad(80), DegToRad(80), 0.0}};
  for (const ModelInfo& info : RegisteredModels()) {
    const std::string ref = MostExactReference(info.name);
    const std::vector<double> p0 = BenchParams(info);
    auto add = [&](const std::string& axis, const std::string& value, const std::vector<double>& p,
                   const std::vector<Angles<double>>& geoms) {
      StabilityCell c = Classify(info, ref, p, geoms, &rep);
      c.axis = axis;
      c.value = value;
      rep.cells.push_back(c);
    };
    for (double deg : {89.0, 89.9, 89.99, 90.0}) {
      const double t = DegToRad(deg);
      std::vector<Angles<double>> geoms;
      for (double ph : {0.0, kHalfPi, kPi}) {
        geoms.push_back({t, t, ph});
        geoms.push_back({t, DegToRad(30), ph});
      }
      add("theta->90", Fmt(deg) + " deg", p0, geoms);
    }
    for (int k = 0; k < info.num_params(); ++k) {
      const ParamInfo& q = info.params[k];
      const double range = q.max - q.min;
      auto with = [&](double v) {
        std::vector<double> p = p0;
        p[k] = v;
        return p;
      };
      for (double f : {0.0, 1e-6, 1e-3}) {
        add(q.name + "->min", q.name + "=" + Fmt(q.min + f * range), with(q.min + f * range),
            param_geoms);
      }
      for (double f : {1e-3, 0.0}) {
        add(q.name + "->max", q.name + "=" + Fmt(q.max - f * range), with(q.max - f * range),
            param_geoms);
      }
      // Past the bound (e.g. rms slope r > 1): must be an explicit error, never a number.
      add(q.name + " out of range", q.name + "=" + Fmt(q.max + 0.5 * range),
          with(q.max + 0.5 * range), param_geoms);
    }
    progress.Step();
  }
  progress.Done();
  return rep;
}

StabilityReport RunStabilitySweeps(const BenchSizes& s, const std::vector<StabilityHook>& hooks) {
  StabilityReport rep = RunModelStability(s);
  StabilityReport fits = RunFitStability(s);
  rep.cells.insert(rep.cells.end(), fits.cells.begin(), fits.cells.end());
  rep.nonfinite_escaped += fits.nonfinite_escaped;
  rep.raw_nonfinite += fits.raw_nonfinite;
  for (const StabilityHook& h : hooks) {
    for (StabilityCell c : h.run(s)) {
      if (c.status != "valid" && c.status != "degraded" && c.status != "error") {
        throw std::logic_error("stability hook " + h.name + ": unknown status " + c.status);
      }
      rep.cells.push_back(c);
    }
  }
  return rep;
}

nlohmann::json StabilityReport::ToJson() const {
  nlohmann::json j;
  j["tolerance_albedo_over_pi"] = kDegradedTolerance;
  j["nonfinite_escaped"] = nonfinite_escaped;
  j["raw_formula_nonfinite_caught"] = raw_nonfinite;
  // Per subject and axis the worst status over the axis' points (the map), plus counts.
  std::map<std::string, std::map<std::string, int>> counts;
  nlohmann::json map = nlohmann::json::object();
  auto rank = [](const std::string& st) { return st == "error" ? 2 : st == "degraded" ? 1 : 0; };
  for (const auto& c : cells) {
    counts[c.subject][c.status]++;
    nlohmann::json& entry = map[c.subject];
    entry["method"] = c.method;
    nlohmann::json& cur = entry["axes"][c.axis];
    if (cur.is_null() || rank(c.status) > rank(cur.get<std::string>())) cur = c.status;
  }
  j["map"] = map;
  nlohmann::json summary = nlohmann::json::object();
  for (const auto& [subject, m] : counts) {
    summary[subject] = {{"valid", m.count("valid") ? m.at("valid") : 0},
                        {"degraded", m.count("degraded") ? m.at("degraded") : 0},
                        {"error", m.count("error") ? m.at("error") : 0}};
  }
  j["summary"] = summary;
  nlohmann::json arr = nlohmann::json::array();
  for (const auto& c : cells) {
    arr.push_back({{"subject", c.subject},
                   {"method", c.method},
                   {"axis", c.axis},
                   {"value", c.value},
                   {"status", c.status},
                   {"detail", c.detail}});
  }
  j["cells"] = arr;
  return j;
}

}  // namespace gonio::bench
