// observations.csv (estimation/extract/observations.h, ReadObservations): an accepted set holds
// only finite numbers, radiance and variance per channel, non-negative variances, and survives
// WriteObservations -> ReadObservations unchanged (assumptions included).
#include "estimation/extract/observations.h"
#include "fuzz/fuzz_util.h"

namespace {

void CheckSet(const gonio::ObservationSet& set) {
  using gonio::fuzz::Finite;
  GONIO_FUZZ_REQUIRE(set.channels >= 1);
  for (const auto& o : set.observations) {
    GONIO_FUZZ_REQUIRE(o.frame >= 0);
    GONIO_FUZZ_REQUIRE(Finite(o.px) && Finite(o.py));
    GONIO_FUZZ_REQUIRE(o.p_in_board.allFinite() && o.camera_in_board.allFinite() &&
                       o.board_from_cam_aa.allFinite());
    GONIO_FUZZ_REQUIRE(o.num_pixels >= 1);
    GONIO_FUZZ_REQUIRE(static_cast<int>(o.radiance.size()) == set.channels);
    GONIO_FUZZ_REQUIRE(o.variance.size() == o.radiance.size());
    for (double v : o.radiance) GONIO_FUZZ_REQUIRE(Finite(v));
    for (double v : o.variance) GONIO_FUZZ_REQUIRE(Finite(v) && v >= 0);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return gonio::fuzz::Run([&] {
    const auto path = gonio::fuzz::WriteInput(data, size, "observations.csv");
    const gonio::ObservationSet set = gonio::ReadObservations(path);
    CheckSet(set);
    const auto copy = gonio::fuzz::WorkDir() / "round_trip.csv";
    gonio::WriteObservations(copy, set);
    const gonio::ObservationSet again = gonio::ReadObservations(copy);
    GONIO_FUZZ_REQUIRE(again.observations.size() == set.observations.size());
    GONIO_FUZZ_REQUIRE(again.channels == set.channels);
    GONIO_FUZZ_REQUIRE(again.assumptions == set.assumptions);
  });
}
