// The gonio Python module (pybind11): the model registry, vectorised evaluation, table fits,
// fit.json reading and export. Angles are in degrees, as on the command line. docs/python.md.
#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>
#include <pybind11/stl.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "common/error.h"
#include "common/math.h"
#include "common/parallel.h"
#include "estimation/fit/brdf_table.h"
#include "estimation/fit/model_selection.h"
#include "export/export.h"
#include "reflectance/registry.h"

namespace py = pybind11;

namespace gonio::python {
namespace {

using Array = py::array_t<double, py::array::c_style | py::array::forcecast>;

py::object FromJson(const nlohmann::json& j) {
  switch (j.type()) {
    case nlohmann::json::value_t::null:
      return py::none();
    case nlohmann::json::value_t::boolean:
      return py::bool_(j.get<bool>());
    case nlohmann::json::value_t::number_integer:
    case nlohmann::json::value_t::number_unsigned:
      return py::int_(j.get<long long>());
    case nlohmann::json::value_t::number_float:
      return py::float_(j.get<double>());
    case nlohmann::json::value_t::string:
      return py::str(j.get<std::string>());
    case nlohmann::json::value_t::array: {
      py::list l;
      for (const auto& v : j) l.append(FromJson(v));
      return std::move(l);
    }
    default: {
      py::dict d;
      for (auto it = j.begin(); it != j.end(); ++it) d[py::str(it.key())] = FromJson(it.value());
      return std::move(d);
    }
  }
}

// A parameter dict onto the registry vector (defaults for missing keys).
std::vector<double> ParamVector(const ModelInfo& info, const py::dict& params) {
  std::vector<double> p;
  for (const auto& pi : info.params) p.push_back(pi.default_value);
  for (const auto& item : params) {
    const std::string key = py::str(item.first);
    int k = -1;
    for (int i = 0; i < info.num_params(); ++i) {
      if (info.params[i].name == key) k = i;
    }
    if (k < 0) throw InputError("model " + info.name + " has no parameter '" + key + "'");
    p[k] = item.second.cast<double>();
  }
  CheckParams(info, p);
  return p;
}

py::list Models() {
  py::list out;
  for (const ModelInfo& m : RegisteredModels()) {
    py::list params;
    for (const auto& p : m.params) {
      params.append(
          py::dict(py::arg("name") = p.name, py::arg("unit") = p.unit, py::arg("min") = p.min,
                   py::arg("max") = p.max, py::arg("default") = p.default_value,
                   py::arg("description") = p.description, py::arg("per_channel") = p.per_channel));
    }
    out.append(py::dict(py::arg("name") = m.name, py::arg("params") = params,
                        py::arg("description") = m.description, py::arg("reference") = m.reference,
                        py::arg("method") = m.method,
                        py::arg("auto_candidate") = m.auto_candidate));
  }
  return out;
}

// f_r (1/sr) broadcast over the three angle arrays (degrees). Rows where the model has no
// valid value (outside [0, 90] deg, both directions at the horizon) are NaN.
py::array Evaluate(const std::string& model, const py::dict& params, const py::object& theta_i,
                   const py::object& theta_r, const py::object& phi, int threads) {
  const ModelInfo& info = FindModel(model);
  const std::vector<double> p = ParamVector(info, params);
  py::tuple b = py::module_::import("numpy").attr("broadcast_arrays")(theta_i, theta_r, phi);
  const Array ti = Array::ensure(b[0]), tr = Array::ensure(b[1]), ph = Array::ensure(b[2]);
  if (!ti || !tr || !ph) throw InputError("evaluate: angles must be numbers or numeric arrays");
  const size_t n = ti.size();
  std::vector<py::ssize_t> shape(ti.shape(), ti.shape() + ti.ndim());
  Array out(shape);
  const double* a = ti.data();
  const double* r = tr.data();
  const double* f = ph.data();
  double* o = out.mutable_data();
  {
    py::gil_scoped_release release;
    // One pass per cache-sized chunk (degrees to radians, the registry's batch evaluation on
    // one thread, validity), chunks in parallel: no extra full-size arrays.
    constexpr double kDeg = kPi / 180.0;
    const double horizon_deg = 90.0 - RadToDeg(1e-9);  // BothAtHorizon: cos < 1e-9
    constexpr size_t kChunk = 2048;
    ParallelFor((n + kChunk - 1) / kChunk, threads, [&](size_t first, size_t last) {
      double rad[3][kChunk];
      for (size_t chunk = first; chunk < last; ++chunk) {
        const size_t begin = chunk * kChunk, m = std::min(n, begin + kChunk) - begin;
        for (size_t k = 0; k < m; ++k) {
          rad[0][k] = a[begin + k] * kDeg;
          rad[1][k] = r[begin + k] * kDeg;
          rad[2][k] = f[begin + k] * kDeg;
        }
        EvaluateBatch(model, p, rad[0], rad[1], rad[2], m, o + begin, 1);
        for (size_t k = begin; k < begin + m; ++k) {
          const bool in_domain = a[k] >= 0 && a[k] <= 90 && r[k] >= 0 && r[k] <= 90;
          const bool horizon = a[k] > horizon_deg && r[k] > horizon_deg;
          if (!in_domain || horizon || !std::isfinite(o[k])) o[k] = std::nan("");
        }
      }
    });
  }
  return std::move(out);
}

py::dict FitTable(const Array& theta_i, const Array& theta_r, const Array& phi, const Array& value,
                  const py::object& weight, const py::object& models, const std::string& criterion,
                  bool relative, int threads) {
  // array_t sizes are signed (py::ssize_t): one type for every comparison below.
  const py::ssize_t n = value.size();
  if (theta_i.size() != n || theta_r.size() != n || phi.size() != n) {
    throw InputError("fit_table: theta_i, theta_r, phi and value must have the same length");
  }
  Array w;  // a default array_t is an empty array, not a null handle: test has_weight
  const bool has_weight = !weight.is_none();
  if (has_weight) {
    w = Array::ensure(weight);
    if (!w || w.size() != n) throw InputError("fit_table: weight must match value's length");
  }
  std::vector<BrdfSample> samples(static_cast<size_t>(n));
  for (py::ssize_t k = 0; k < n; ++k) {
    samples[static_cast<size_t>(k)] = {DegToRad(theta_i.data()[k]), DegToRad(theta_r.data()[k]),
                                       DegToRad(phi.data()[k]), value.data()[k],
                                       has_weight ? w.data()[k] : 1.0};
  }
  ModelSelectionOptions opt;
  if (!models.is_none()) opt.candidates = models.cast<std::vector<std::string>>();
  opt.criterion = ParseCriterion(criterion, "criterion");
  opt.threads = threads;
  opt.fit.relative_scale = relative;
  opt.Check();
  ModelSelectionResult sel;
  {
    py::gil_scoped_release release;
    sel = SelectModel(samples, opt);
  }
  return FromJson(ToJson(sel)).cast<py::dict>();
}

py::dict LoadTable(const std::string& path, const std::string& merl_channel) {
  BrdfTable table;
  if (std::filesystem::path(path).extension() == ".binary") {
    MerlTableOptions mopt;
    mopt.channel = ParseMerlChannel(merl_channel);
    table = LoadMerlBinary(path, mopt);
  } else {
    const CsvTable csv = CsvTable::Read(path);
    BrdfTableOptions topt;
    if (IsAstmE1392Table(csv)) topt = AstmE1392Options(topt);
    table = LoadBrdfTable(csv, topt);
  }
  const size_t n = table.samples.size();
  Array ti(n), tr(n), ph(n), v(n), w(n);
  for (size_t k = 0; k < n; ++k) {
    const BrdfSample& s = table.samples[k];
    ti.mutable_data()[k] = RadToDeg(s.theta_i), tr.mutable_data()[k] = RadToDeg(s.theta_r);
    ph.mutable_data()[k] = RadToDeg(s.phi), v.mutable_data()[k] = s.value;
    w.mutable_data()[k] = s.weight;
  }
  return py::dict(py::arg("theta_i") = ti, py::arg("theta_r") = tr, py::arg("phi") = ph,
                  py::arg("value") = v, py::arg("weight") = w);
}

py::dict MaterialDict(const FittedMaterial& m) {
  const ModelInfo& info = FindModel(m.model);
  py::dict params;
  for (int k = 0; k < info.num_params(); ++k) params[py::str(info.params[k].name)] = m.params[k];
  Array channels({3, info.num_params()});
  for (int c = 0; c < 3; ++c) {
    for (int k = 0; k < info.num_params(); ++k) {
      channels.mutable_data()[c * info.num_params() + k] = m.channel_params[c][k];
    }
  }
  return py::dict(py::arg("model") = m.model, py::arg("params") = params,
                  py::arg("channel_params") = channels, py::arg("per_channel") = m.per_channel,
                  py::arg("source") = m.source);
}

py::dict ReadFit(const std::string& path, bool allow_relative) {
  ReadFitOptions opt;
  opt.allow_relative = allow_relative;
  return MaterialDict(ReadFitFile(path, opt));
}

py::dict Export(const std::string& format, const std::string& out, const py::object& fit,
                const py::object& model, const py::dict& params, double max_theta,
                bool allow_relative) {
  if (fit.is_none() == model.is_none()) {
    throw InputError("export: give either fit=PATH or model=NAME (with params)");
  }
  FittedMaterial m;
  if (!fit.is_none()) {
    ReadFitOptions ropt;
    ropt.allow_relative = allow_relative;
    m = ReadFitFile(fit.cast<std::string>(), ropt);
  } else {
    const std::string name = model.cast<std::string>();
    m = MakeMaterial(name, ParamVector(FindModel(name), params));
  }
  ExportOptions opt;
  opt.format = ParseExportFormat(format);
  opt.domain.max_theta_deg = max_theta;
  ExportResult r;
  {
    py::gil_scoped_release release;
    r = ExportMaterial(m, opt, out);
  }
  py::dict d(py::arg("format") = format, py::arg("n_values") = r.n_values,
             py::arg("report") = r.Report());
  if (r.renderer) {
    d["exact"] = r.renderer->exact;
    d["shape"] = r.renderer->shape;
    d["albedo"] =
        py::make_tuple(r.renderer->albedo[0], r.renderer->albedo[1], r.renderer->albedo[2]);
    d["rel_rms"] = r.renderer->rel_rms;
    d["rel_max"] = r.renderer->rel_max;
  }
  return d;
}

}  // namespace
}  // namespace gonio::python

PYBIND11_MODULE(gonio, m) {
  using namespace gonio::python;
  m.doc() = "gonio: BRDF models, fits and exports (angles in degrees, f_r in 1/sr)";
  py::register_exception<gonio::InputError>(m, "InputError", PyExc_ValueError);
  py::register_exception<gonio::NumericalError>(m, "NumericalError", PyExc_ArithmeticError);
  m.def("models", &Models, "Every registry model with its parameters (name, unit, range, ...)");
  m.def("evaluate", &Evaluate, py::arg("model"), py::arg("params"), py::arg("theta_i"),
        py::arg("theta_r"), py::arg("phi"), py::arg("threads") = 0,
        "f_r in 1/sr, broadcast over the angle arrays (degrees; phi = 0 backscatter). NaN "
        "where the model has no valid value.");
  m.def("fit_table", &FitTable, py::arg("theta_i"), py::arg("theta_r"), py::arg("phi"),
        py::arg("value"), py::arg("weight") = py::none(), py::arg("models") = py::none(),
        py::arg("criterion") = "bic", py::arg("relative") = false, py::arg("threads") = 0,
        "Fit registry models to BRDF samples (degrees) and choose the simplest adequate one; "
        "returns fit-table's fit.json content as a dict");
  m.def("load_table", &LoadTable, py::arg("path"), py::arg("merl_channel") = "mean",
        "Read a CSV, ASTM E1392 or MERL .binary table as arrays (degrees)");
  m.def("read_fit", &ReadFit, py::arg("path"), py::arg("allow_relative") = false,
        "The material of a fit.json: model, params dict, channel_params (3 x n array)");
  m.def("export", &Export, py::arg("format"), py::arg("out"), py::arg("fit") = py::none(),
        py::arg("model") = py::none(), py::arg("params") = py::dict(), py::arg("max_theta") = 80.0,
        py::arg("allow_relative") = false,
        "gonio export: mitsuba, pbrt3, blender, materialx, astm or merl");
  m.def(
      "bench_batch",
      [](const std::string& model, const py::dict& params, const Array& theta_i,
         const Array& theta_r, const Array& phi, int repeats, int threads) {
        // The C++ batch on the same angles (radians in, no Python in the loop) timed in C++: the
        // reference of python/bench_evaluate.py. Returns the best time per value in ns.
        const std::vector<double> p = ParamVector(gonio::FindModel(model), params);
        if (theta_r.size() != theta_i.size() || phi.size() != theta_i.size()) {
          throw gonio::InputError("bench_batch: sizes");
        }
        const auto n = static_cast<size_t>(theta_i.size());
        std::vector<double> out(n);
        py::gil_scoped_release release;
        double best = INFINITY;
        for (int r = 0; r < repeats; ++r) {
          const auto t0 = std::chrono::steady_clock::now();
          gonio::EvaluateBatch(model, p, theta_i.data(), theta_r.data(), phi.data(), n, out.data(),
                               threads);
          const std::chrono::duration<double, std::nano> dt = std::chrono::steady_clock::now() - t0;
          best = std::min(best, dt.count() / n);
        }
        return best;
      },
      py::arg("model"), py::arg("params"), py::arg("theta_i"), py::arg("theta_r"), py::arg("phi"),
      py::arg("repeats") = 5, py::arg("threads") = 0);
}
