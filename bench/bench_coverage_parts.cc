// `gonio bench --coverage --by-parts`: each run's error split by source and set against what
// the bars drew of it (bench/bench_coverage.h CoveragePart, docs/bench.md).
#include <algorithm>
#include <cmath>
#include <map>
#include <numeric>
#include <stdexcept>

#include <fmt/format.h>

#include "bench/bench_coverage.h"
#include "calib/photometry/synth_photometric.h"
#include "common/io.h"

namespace fs = std::filesystem;
using nlohmann::json;

namespace gonio::bench {
namespace {

// `args` with the value after `option` replaced by `value` (appended when absent).
std::vector<std::string> WithOption(std::vector<std::string> args, const std::string& option,
                                    const std::string& value) {
  for (size_t i = 0; i + 1 < args.size(); ++i) {
    if (args[i] == option) {
      args[i + 1] = value;
      return args;
    }
  }
  args.push_back(option);
  args.push_back(value);
  return args;
}

// The judged values of a variant's fit.json (JudgeFit: the true model's parameters when it
// was selected, the lamp's axes), by parameter.
std::map<std::string, double> ValuesOf(const json& fit, const json& truth) {
  CoverageRun judged;
  JudgeFit(fit, truth, &judged);
  std::map<std::string, double> values;
  for (const auto& v : judged.values) values[v.parameter] = v.value;
  return values;
}

// What the user's error budget drew of each part: response, vignetting, and the statistical
// and poses' parts in quadrature; -1 where it holds none.
void Drawn(const json& user_fit, CoveragePart* p) {
  const json budget = user_fit.value("error_budget", json());
  if (!budget.is_object() || !budget.at("stddev").contains(p->parameter)) return;
  const json& row = budget.at("stddev").at(p->parameter);
  const json& sources = row.at("sources");
  const auto source = [&](const char* name) {
    return sources.contains(name) && sources.at(name).is_number() ? sources.at(name).get<double>()
                                                                  : 0.0;
  };
  p->drawn_response = source("response");
  p->drawn_vignetting = source("vignetting");
  p->drawn_rest = std::hypot(row.at("statistical").get<double>(), source("poses"));
}

double Correlation(const std::vector<double>& a, const std::vector<double>& b) {
  const size_t n = a.size();
  if (n < 3) return 0;
  double ma = 0, mb = 0;
  for (size_t i = 0; i < n; ++i) ma += a[i] / n, mb += b[i] / n;
  double ab = 0, aa = 0, bb = 0;
  for (size_t i = 0; i < n; ++i) {
    ab += (a[i] - ma) * (b[i] - mb);
    aa += (a[i] - ma) * (a[i] - ma);
    bb += (b[i] - mb) * (b[i] - mb);
  }
  return aa > 0 && bb > 0 ? ab / std::sqrt(aa * bb) : 0.0;
}

double Rms(const std::vector<double>& v) {
  double s = 0;
  for (double x : v) s += x * x;
  return v.empty() ? 0.0 : std::sqrt(s / v.size());
}

}  // namespace

json CoveragePart::ToJson() const {
  return {{"parameter", parameter},
          {"response", response},
          {"vignetting", vignetting},
          {"rest", rest},
          {"drawn",
           {{"response", drawn_response}, {"vignetting", drawn_vignetting}, {"rest", drawn_rest}}}};
}

json CoveragePartStat::ToJson() const {
  json parts = json::object();
  const char* names[] = {"response", "vignetting", "rest"};
  for (int k = 0; k < 3; ++k) {
    parts[names[k]] = {{"rms_error", error[k]},
                       {"mean_error", mean[k]},
                       {"rms_drawn", drawn[k]},
                       {"error_over_drawn", drawn[k] > 0 ? json(error[k] / drawn[k]) : json()}};
  }
  return {{"parameter", parameter},
          {"n", n},
          {"parts", parts},
          {"correlation",
           {{"response_vignetting", correlation[0]},
            {"response_rest", correlation[1]},
            {"vignetting_rest", correlation[2]}}}};
}

std::vector<CoveragePartStat> SummarizeParts(const std::vector<CoverageRun>& runs) {
  std::vector<std::string> names;
  std::map<std::string, std::vector<const CoveragePart*>> by_name;
  for (const auto& r : runs) {
    for (const auto& p : r.parts) {
      const auto v = std::find_if(r.values.begin(), r.values.end(), [&](const CoverageValue& x) {
        return x.parameter == p.parameter;
      });
      if (v == r.values.end() || v->warned || p.drawn_rest < 0) continue;
      if (!by_name.count(p.parameter)) names.push_back(p.parameter);
      by_name[p.parameter].push_back(&p);
    }
  }
  std::vector<CoveragePartStat> stats;
  for (const auto& name : names) {
    CoveragePartStat s;
    s.parameter = name;
    s.n = static_cast<int>(by_name[name].size());
    std::vector<double> e[3], d[3];
    for (const CoveragePart* p : by_name[name]) {
      const double errors[] = {p->response, p->vignetting, p->rest};
      const double draws[] = {p->drawn_response, p->drawn_vignetting, p->drawn_rest};
      for (int k = 0; k < 3; ++k) e[k].push_back(errors[k]), d[k].push_back(draws[k]);
    }
    for (int k = 0; k < 3; ++k) {
      s.error[k] = Rms(e[k]);
      s.mean[k] = std::accumulate(e[k].begin(), e[k].end(), 0.0) / static_cast<double>(s.n);
      s.drawn[k] = Rms(d[k]);
    }
    s.correlation[0] = Correlation(e[0], e[1]);
    s.correlation[1] = Correlation(e[0], e[2]);
    s.correlation[2] = Correlation(e[1], e[2]);
    stats.push_back(s);
  }
  return stats;
}

void JudgeParts(const fs::path& session, const fs::path& user_photometric, const json& user_fit,
                const std::vector<std::string>& run_args,
                const std::vector<std::string>& vignette_args, const fs::path& parts_dir,
                const std::function<void(const std::string&, std::vector<std::string>)>& step,
                CoverageRun* run) {
  EnsureDirectory(parts_dir);
  const json truth = ReadJsonFile(session / "truth.json");
  const json accuracy = ReadJsonFile(user_photometric).value("relative_accuracy", json());
  // C: the renderer's response and V, with the user's floor so that only the values differ.
  const json& camera = truth.at("camera");
  PhotometricFromSynthTruth(truth, camera.at("width").get<int>(), camera.at("height").get<int>())
      .Write(parts_dir / "c_photometric.json");
  json c = ReadJsonFile(parts_dir / "c_photometric.json");
  c["relative_accuracy"] = accuracy;
  WriteJsonAtomically(parts_dir / "c_photometric.json", c);
  // B: V fitted through the renderer's response.
  WriteJsonAtomically(parts_dir / "true_response.json", c.at("response"));
  std::vector<std::string> vignette =
      WithOption(vignette_args, "--response", (parts_dir / "true_response.json").string());
  vignette = WithOption(vignette, "--out", (parts_dir / "b_vignette.tiff").string());
  step("parts-vignette-" + run->sweep,
       WithOption(vignette, "--photometric-out", (parts_dir / "b_photometric.json").string()));
  json b = ReadJsonFile(parts_dir / "b_photometric.json");
  b["relative_accuracy"] = accuracy;
  WriteJsonAtomically(parts_dir / "b_photometric.json", b);
  std::map<std::string, double> variant[2];
  const char* names[] = {"b", "c"};
  for (int k = 0; k < 2; ++k) {
    const fs::path out = parts_dir / fmt::format("run-{}", names[k]);
    std::vector<std::string> args =
        WithOption(run_args, "--photometric",
                   (parts_dir / fmt::format("{}_photometric.json", names[k])).string());
    step(fmt::format("parts-run-{}-{}", names[k], run->sweep),
         WithOption(args, "--out", out.string()));
    variant[k] = ValuesOf(ReadJsonFile(out / "fit.json"), truth);
  }
  for (const CoverageValue& v : run->values) {
    const auto b = variant[0].find(v.parameter), c = variant[1].find(v.parameter);
    if (b == variant[0].end() || c == variant[1].end()) continue;  // another model chosen
    CoveragePart p;
    p.parameter = v.parameter;
    p.response = v.value - b->second;
    p.vignetting = b->second - c->second;
    p.rest = c->second - v.truth;
    Drawn(user_fit, &p);
    run->parts.push_back(p);
  }
}

}  // namespace gonio::bench
