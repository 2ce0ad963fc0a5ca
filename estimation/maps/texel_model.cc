#include "estimation/maps/texel_model.h"

#include "common/error.h"
#include "common/option_words.h"

namespace gonio {
namespace {

constexpr OptionWord<MapsModel> kModelWords[] = {
    {MapsModel::kLambert, "lambert"},
    {MapsModel::kOrenNayarQualitative, "oren-nayar-qualitative"},
    {MapsModel::kOrenNayar, "oren-nayar"},
    {MapsModel::kDiffuseGgx, "diffuse-ggx"}};

}  // namespace

MapsModel ParseMapsModel(const std::string& word, const std::string& option) {
  return ParseOptionWord(kModelWords, word, option);
}

std::string ToString(MapsModel model) { return OptionWordOf(kModelWords, model); }

MapsModelInfo InfoOf(MapsModel model) {
  MapsModelInfo info;
  info.channel_param_names[0] = "albedo";
  switch (model) {
    case MapsModel::kLambert:
      break;
    case MapsModel::kOrenNayarQualitative:
    case MapsModel::kOrenNayar:
      // The registry's range of sigma (reflectance/oren_nayar.h); the start is the middle of
      // the rough-diffuse samples gonio meets (30 deg).
      info.has_roughness = true;
      info.roughness_lo = 0.0;
      info.roughness_hi = 0.9;
      info.roughness_start = 0.5;
      info.roughness_name = "sigma";
      info.roughness_unit = "rad";
      break;
    case MapsModel::kDiffuseGgx:
      info.channel_params = 2;
      info.channel_param_names[0] = "diffuse";
      info.channel_param_names[1] = "specular";
      info.has_roughness = true;
      info.roughness_lo = 0.02;
      info.roughness_hi = 1.0;
      info.roughness_start = 0.3;
      info.roughness_name = "alpha";
      info.roughness_unit = "1";
      break;
  }
  return info;
}

}  // namespace gonio
