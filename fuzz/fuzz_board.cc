// board.json (calib/geometry/board.h, Board::Read): an accepted board has finite corner positions
// and survives its own ToJson -> FromJson round trip unchanged.
#include "calib/geometry/board.h"
#include "fuzz/fuzz_util.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  return gonio::fuzz::Run([&] {
    const auto path = gonio::fuzz::WriteInput(data, size, "board.json");
    const gonio::Board board = gonio::Board::Read(path);
    GONIO_FUZZ_REQUIRE(!board.Points().empty());
    for (const auto& p : board.Points()) GONIO_FUZZ_REQUIRE(p.allFinite());
    for (const auto& p : board.sample_region()) GONIO_FUZZ_REQUIRE(p.allFinite());
    for (const auto& p : board.white_region()) GONIO_FUZZ_REQUIRE(p.allFinite());
    const nlohmann::json j = board.ToJson();
    const gonio::Board again = gonio::Board::FromJson(j, "round trip");
    GONIO_FUZZ_REQUIRE(again.ToJson() == j);
    GONIO_FUZZ_REQUIRE(again.Points() == board.Points());
  });
}
