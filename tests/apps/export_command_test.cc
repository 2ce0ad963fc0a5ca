// gonio export through the executable: a fit.json of either layout (fit-table's candidates,
// gonio fit's "final" block with per-channel albedo) in every format, and the inputs it refuses.
// The formats' formulas are tested in tests/export.
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/io.h"
#include "export/export.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

// A fit-table fit.json (selected + candidates), or with `relative` a free-scale one.
std::filesystem::path WriteFitJson(const std::filesystem::path& dir, bool relative) {
  nlohmann::json cand = {
      {"model", "oren-nayar"}, {"params", {{"albedo", 0.55}, {"sigma", 0.3}}}, {"converged", true}};
  if (relative) cand["scale"] = 2.0;
  const nlohmann::json j = {{"selected", "oren-nayar"}, {"candidates", {cand}}};
  const auto path = dir / (relative ? "rel.json" : "fit.json");
  WriteJsonAtomically(path, j);
  return path;
}

// The layout of `gonio fit` (the demo's fit.json): the "final" block wins over the candidates,
// per-channel albedo, an absolute lamp.
std::filesystem::path WriteJointFitJson(const std::filesystem::path& dir) {
  const nlohmann::json cand = {
      {"model", "oren-nayar"}, {"params", {{"albedo", 0.5}, {"sigma", 0.2}}}, {"converged", true}};
  const nlohmann::json final_fit = {{"model", "oren-nayar"},
                                    {"params", {{"albedo", 0.6}, {"sigma", 0.5236}}},
                                    {"params_per_channel", {{"albedo", {0.62, 0.6, 0.58}}}},
                                    {"converged", true}};
  const nlohmann::json j = {{"selected", "oren-nayar"},
                            {"candidates", {cand}},
                            {"final", final_fit},
                            {"lamp", {{"absolute", true}}}};
  const auto path = dir / "joint.json";
  WriteJsonAtomically(path, j);
  return path;
}

TEST(ExportCli, JointFitUsesFinalBlockAndChannels) {
  testing::TempDir dir;
  const FittedMaterial m = ReadFitFile(WriteJointFitJson(dir.path()));
  EXPECT_EQ(m.model, "oren-nayar");
  EXPECT_DOUBLE_EQ(m.params[1], 0.5236);
  EXPECT_TRUE(m.per_channel);
  EXPECT_DOUBLE_EQ(m.channel_params[0][0], 0.62);
  EXPECT_DOUBLE_EQ(m.channel_params[2][0], 0.58);
  const auto out = dir.path() / "m.xml";
  const auto r = testing::RunGonio("export --fit " + WriteJointFitJson(dir.path()).string() +
                                   " --format mitsuba --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(ReadTextFile(out).find("value=\"0.62, 0.6, 0.58\""), std::string::npos);
}

// A joint fit without a white reference says so in its lamp block ("lamp", or "light" in
// fit.json files written before the rename, docs/formats.md "Renamed keys"): relative either way.
TEST(ExportCli, ARelativeLampIsReadUnderItsOldKeyToo) {
  testing::TempDir dir;
  for (const char* key : {"lamp", "light"}) {
    nlohmann::json j = ReadJsonFile(WriteJointFitJson(dir.path()));
    j.erase("lamp");
    j[key] = {{"absolute", false}};
    const auto path = dir.path() / (std::string(key) + ".json");
    WriteJsonAtomically(path, j);
    const std::string msg = testing::InputErrorOf([&] { ReadFitFile(path); });
    EXPECT_NE(msg.find("relative"), std::string::npos) << key << ": " << msg;
    EXPECT_NO_THROW(ReadFitFile(path, ReadFitOptions{true})) << key;
  }
}

TEST(ExportCli, EveryFormatFromFitJson) {
  testing::TempDir dir;
  const auto fit = WriteFitJson(dir.path(), false);
  for (const std::string f : {"mitsuba", "pbrt3", "blender", "materialx", "astm", "merl"}) {
    const auto out = dir.path() / ("out_" + f);
    const auto r = testing::RunGonio("export --fit " + fit.string() + " --format " + f + " --out " +
                                     out.string());
    EXPECT_EQ(r.exit_code, 0) << f << ": " << r.err;
    EXPECT_TRUE(std::filesystem::exists(out)) << f;
    EXPECT_NE(r.out.find("oren-nayar"), std::string::npos) << r.out;
  }
}

TEST(ExportCli, BadInputExitsTwoAndWritesNothing) {
  testing::TempDir dir;
  const auto rel = WriteFitJson(dir.path(), true);
  const auto out = dir.path() / "x.xml";
  auto r =
      testing::RunGonio("export --fit " + rel.string() + " --format mitsuba --out " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("relative"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
  r = testing::RunGonio("export --fit " + WriteFitJson(dir.path(), false).string() +
                        " --format obj --out " + out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--format"), std::string::npos) << r.err;
  r = testing::RunGonio(
      "export --model oren-nayar --param sigma=0.3 --format pbrt3 --max-theta 95"
      " --out " +
      out.string());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("--max-theta"), std::string::npos) << r.err;
  EXPECT_FALSE(std::filesystem::exists(out));
}

}  // namespace
}  // namespace gonio
