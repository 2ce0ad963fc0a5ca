// gonio plan through the executable: the files it writes (a lamp in the board frame or a flash)
// and the options it refuses with one line and exit 2. What the plan predicts and selects is
// tested in tests/pipeline/plan_test.cc.
#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "common/io.h"
#include "pipeline/plan.h"
#include "tests/pipeline/plan_test_util.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;

// Board and camera files of the 640x480 preset for the CLI cases.
class PlanCli : public testing::PlanFixture {
 protected:
  void SetUp() override {
    WriteJsonAtomically(dir_.path() / "board.json", board_.ToJson());
    scene_.camera.Write(dir_.path() / "camera.cameramodel");
  }
  std::string Args(const std::string& extra) const {
    return fmt::format(
        "plan --board {} --camera {} --out {} {}", (dir_.path() / "board.json").string(),
        (dir_.path() / "camera.cameramodel").string(), (dir_.path() / "plan").string(), extra);
  }
  testing::TempDir dir_;
};

TEST_F(PlanCli, WritesThePlanFiles) {
  const auto r = testing::RunGonio(
      Args("--lamp -0.1318,0.095,-0.4096 --material oren-nayar:sigma=0.5236,albedo=0.6 "
           "--white-albedo 0.8 --views 6"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* f : {"plan.json", "plan.csv", "plan.png", "coverage.png"}) {
    EXPECT_TRUE(fs::exists(dir_.path() / "plan" / f)) << f;
  }
  const nlohmann::json j = ReadJsonFile(dir_.path() / "plan" / "plan.json");
  EXPECT_EQ(j.at("views").size(), 6u);
  EXPECT_EQ(ReadPlanPoses(dir_.path() / "plan" / "plan.json").size(), 6u);
  // A flash: the lamp moves with the camera.
  const auto f = testing::RunGonio(
      Args("--lamp flash --material oren-nayar:sigma=0.5236,albedo=0.6 --white-albedo 0.8 "
           "--views 6"));
  EXPECT_EQ(f.exit_code, 0) << f.err;
}

TEST_F(PlanCli, BadInputIsOneLineNamingTheOption) {
  const std::string material = "--material oren-nayar:sigma=0.5,albedo=0.6";
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"--lamp 1,2 " + material, "--lamp"},
      {"--lamp 0.1,0.1,0.5 " + material, "--lamp"},
      {"--lamp 0,0,-0.5 --material oren-nayar:sigma=9", "--material"},
      {"--lamp 0,0,-0.5 --material glass", "--material"},
      {"--lamp 0,0,-0.5 " + material + " --views 0", "--views"},
      {"--lamp 0,0,-0.5 " + material + " --criterion e", "--criterion"},
      {"--lamp 0,0,-0.5 " + material + " --exposure -1", "--exposure"},
      {"--lamp 0,0,-0.5 " + material + " --white-albedo 2", "--white-albedo"}};
  for (const auto& [extra, option] : cases) {
    const auto r = testing::RunGonio(Args(extra));
    EXPECT_EQ(r.exit_code, 2) << extra << "\n" << r.err;
    EXPECT_EQ(testing::MessageLines(r.err), 1) << r.err;
    EXPECT_NE(r.err.find(option), std::string::npos) << r.err;
    EXPECT_FALSE(fs::exists(dir_.path() / "plan")) << extra;
  }
}

}  // namespace
}  // namespace gonio
