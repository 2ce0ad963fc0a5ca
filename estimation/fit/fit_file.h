// The material of a fit.json (`gonio fit` or `gonio fit-table`, docs/formats.md) as plain
// values: the model, its parameters, and per-channel values of its scale parameters.
#pragma once

#include <array>
#include <filesystem>
#include <string>
#include <vector>

namespace gonio {

struct FittedMaterial {
  std::string model;
  std::vector<double> params;  // registry order; scale parameters hold the grey value
  // Parameters per colour channel (R, G, B), registry order: the scale parameters from
  // `params_per_channel` when the fit has them, otherwise three copies of `params`.
  std::array<std::vector<double>, 3> channel_params;
  bool per_channel = false;  // the fit.json gave per-channel scale parameters
  std::string source;        // file it was read from

  std::string Report() const;
};

struct ReadFitOptions {
  // Accept fits whose albedo is only known up to a scale (a free scale in fit-table
  // --relative, or a joint fit without a white reference): the exported shape is right, the
  // exported albedo is not absolute.
  bool allow_relative = false;
  // Every combination is valid; here so that every Options struct can be checked alike.
  void Check() const {}
};

// Reads the joint fit's "final" block when present, else the selected candidate. InputError
// naming the file for a missing or unknown model, a parameter outside its registry range, or a
// relative fit without allow_relative.
FittedMaterial ReadFitFile(const std::filesystem::path& path, const ReadFitOptions& options = {});

// A material from a model name and parameters (grey), checked against the registry.
FittedMaterial MakeMaterial(const std::string& model, const std::vector<double>& params);

}  // namespace gonio
