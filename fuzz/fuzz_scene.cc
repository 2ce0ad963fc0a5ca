// Scene JSON for `gonio synth --scene` (data_synth/scene.h, SceneFromJson as synth reads it):
// an accepted scene passes its own Check() and survives SceneToJson -> SceneFromJson
// unchanged.
#include "common/io.h"
#include "data_synth/scene.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return gonio::fuzz::Run([&] {
    const auto path = gonio::fuzz::WriteInput(data, size, "scene.json");
    const gonio::synth::Scene scene =
        gonio::synth::SceneFromJson(gonio::ReadJsonFile(path), path.string());
    scene.Check();
    GONIO_FUZZ_REQUIRE(scene.camera.IntrinsicsFinite());
    const nlohmann::json j = gonio::synth::SceneToJson(scene);
    const gonio::synth::Scene again = gonio::synth::SceneFromJson(j, "round trip");
    GONIO_FUZZ_REQUIRE(gonio::synth::SceneToJson(again) == j);
  });
}
