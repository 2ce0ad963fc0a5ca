// session.json (common/session.h, ReadSession): an accepted session passes its own Check()
// and holds only finite, positive exposures.
#include <cstdio>

#include "common/session.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  // The files the seed sessions (gonio synth) list, so inputs get past the existence checks.
  char name[32];
  for (int i = 0; i < 64; ++i) {
    std::snprintf(name, sizeof(name), "frame_%04d.png", i);
    gonio::fuzz::Touch(name);
  }
  gonio::fuzz::Touch("board.json");
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using gonio::fuzz::Finite;
  return gonio::fuzz::Run([&] {
    gonio::fuzz::WriteInput(data, size, "session.json");
    const gonio::Session s = gonio::ReadSession(gonio::fuzz::WorkDir());
    s.Check("re-check");  // an accepted session must stay accepted
    GONIO_FUZZ_REQUIRE(!s.frames.empty());
    GONIO_FUZZ_REQUIRE(s.bit_depth == 0 || (s.bit_depth >= 8 && s.bit_depth <= 16));
    for (const auto& f : s.frames) {
      GONIO_FUZZ_REQUIRE(Finite(f.exposure_s) && f.exposure_s > 0);
      GONIO_FUZZ_REQUIRE(Finite(f.gain) && f.gain > 0);
      GONIO_FUZZ_REQUIRE(Finite(f.timestamp));
      GONIO_FUZZ_REQUIRE(f.bracket >= 0);
    }
  });
}
