// Helpers shared by the bench library's source files (not part of its interface).
#pragma once

#include <string>
#include <vector>

#include "reflectance/angles.h"
#include "reflectance/model.h"

namespace gonio::bench {

// Parameters of `ref` (a registry name or the facet high-order name) taken by name from
// `model`'s parameter vector; parameters the model lacks take the reference's default.
std::vector<double> MapParams(const std::string& model, const std::vector<double>& params,
                              const std::string& ref);
// EvaluateChecked, extended to the high-order facet reference.
std::string EvaluateAny(const std::string& name, const std::vector<double>& params,
                        const Angles<double>& a, double* value);
// albedo/pi for the model's first scale parameter (1/pi when it has none or it is 0).
double ErrorUnit(const ModelInfo& info, const std::vector<double>& params);
// Registry defaults: the parameters every bench uses.
std::vector<double> BenchParams(const ModelInfo& info);

}  // namespace gonio::bench
