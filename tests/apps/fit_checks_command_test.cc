// `gonio fit` on observation files makes the checks `gonio run` makes (pipeline/checks.h
// FitChecked; docs/pipeline.md "Checks"): frames of a moved lamp named, two scenes refused,
// impossible radiances refused, the extraction's assumptions carried into fit.json; and its
// output names are checked before the work. Observations come from sessions rendered here and
// extracted with the CLI, as a user's would.
#include <functional>
#include <sstream>

#include <fmt/format.h>
#include <gtest/gtest.h>

#include "common/io.h"
#include "common/math.h"
#include "data_synth/board_renderer.h"
#include "tests/pipeline/pipeline_test_util.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;

using testing::ExpectOneLineError;

// Each line of an observations.csv through `edit(row_index, fields)` (data rows only).
std::string EditRows(const std::string& csv,
                     const std::function<void(size_t, std::vector<std::string>*)>& edit) {
  std::istringstream in(csv);
  std::string line, out;
  size_t row = 0;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#' || line.rfind("frame,", 0) == 0) {
      out += line + "\n";
      continue;
    }
    std::vector<std::string> fields;
    std::istringstream ls(line);
    for (std::string f; std::getline(ls, f, ',');) fields.push_back(f);
    edit(row++, &fields);
    for (size_t k = 0; k < fields.size(); ++k) out += (k ? "," : "") + fields[k];
    out += "\n";
  }
  return out;
}

// Columns of observations.csv (docs/formats.md): L0 after the patch moment's three.
constexpr size_t kRegion = 12, kL0 = 17;

// Session a (oren-nayar, lamp at the preset's place), b (the same views, lamp moved 13 cm) and
// "moved" (a with its last two frames from b), each located and extracted through the CLI.
class FitChecksCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    synth::Scene a = SmallScene("oren-nayar", {{"albedo", 0.6}, {"sigma", DegToRad(30)}});
    a.views.per_ring = 2;
    synth::Scene b = a;
    b.lamp.position += Eigen::Vector3d(0.12, 0.0, 0.05);
    synth::RenderBoardSession(a, Dir("a"), 0);
    synth::RenderBoardSession(b, Dir("b"), 0);
    fs::copy(Dir("a"), Dir("moved"), fs::copy_options::recursive);
    const size_t n = a.CamFromBoardPoses().size();
    for (size_t k = n - 2; k < n; ++k) {
      const std::string f = fmt::format("frame_{:04d}.png", k);
      fs::copy_file(Dir("b") / f, Dir("moved") / f, fs::copy_options::overwrite_existing);
    }
    for (const char* s : {"a", "b", "moved"}) {
      WriteTruePhotometric(Dir(s));
      Extract(Dir(s), "");
    }
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path Dir(const std::string& name) { return dir_->path() / name; }
  static fs::path Observations(const std::string& name) { return Dir(name) / "obs.csv"; }
  // locate + extract of a session into SESSION/obs.csv.
  static void Extract(const fs::path& session, const std::string& extra) {
    const std::string camera = (session / "camera.cameramodel").string();
    const std::string poses = (session / "poses.json").string();
    testing::RunGonioOk(
        fmt::format("locate --session {} --camera {} --out {}", session.string(), camera, poses));
    testing::RunGonioOk(
        fmt::format("extract --session {} --camera {} --poses {} --patch 4 {} "
                    "--out {}",
                    session.string(), camera, poses, extra, (session / "obs.csv").string()));
  }
  static std::string Fit(const std::string& observations, const fs::path& out,
                         const std::string& models = "oren-nayar") {
    return fmt::format("fit --observations {} --models {} --white-albedo 0.8 --out '{}'",
                       observations, models, out.string());
  }
  static testing::TempDir* dir_;
};
testing::TempDir* FitChecksCli::dir_ = nullptr;

// The lamp moved for the last two of eight frames: gonio fit names them, as gonio run does.
TEST_F(FitChecksCli, FramesWhereTheLampMovedAreNamed) {
  testing::TempDir work;
  const fs::path out = work.path() / "fit.json";
  const auto r = testing::RunGonio(Fit(Observations("moved").string(), out));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("WARNING: frames that disagree"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("frame_0007.png"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("frame_0006.png"), std::string::npos) << r.out;
  EXPECT_EQ(r.out.find("frame_0000.png"), std::string::npos) << r.out;
  const nlohmann::json fit = ReadJsonFile(out);
  EXPECT_EQ(fit["checks"]["inconsistent_frames"].size(), 2u) << fit["checks"].dump();
}

// Two files of two scenes fitted as one (half the frames from another session): refused, as
// gonio run refuses such a session, with nothing written.
TEST_F(FitChecksCli, ObservationsOfTwoScenesAreRefused) {
  testing::TempDir work;
  const fs::path out = work.path() / "fit.json";
  ExpectOneLineError(
      testing::RunGonio(Fit(Observations("a").string() + "," + Observations("b").string(), out)),
      "obs.csv", "do not hold one scene");
  EXPECT_FALSE(fs::exists(out));
}

// Radiances no camera gives: a fifth of the sample rows negative, or one of 1e300 (whose
// square is infinite: "rel_rms inf" before). Refused naming the file, nothing written.
TEST_F(FitChecksCli, ImpossibleRadiancesAreRefused) {
  testing::TempDir work;
  const std::string csv = ReadTextFile(Observations("a"));
  const fs::path negative = work.path() / "negative.csv", huge = work.path() / "huge.csv";
  WriteTextAtomically(negative, EditRows(csv, [](size_t row, std::vector<std::string>* f) {
                        if ((*f)[kRegion] == "sample" && row % 5 == 0) {
                          (*f)[kL0] = fmt::format("{}", -std::stod((*f)[kL0]));
                        }
                      }));
  WriteTextAtomically(huge, EditRows(csv, [](size_t row, std::vector<std::string>* f) {
                        if (row == 10) (*f)[kL0] = "1e300";
                      }));
  const fs::path out = work.path() / "fit.json";
  ExpectOneLineError(testing::RunGonio(Fit(negative.string(), out)), "negative.csv", "below zero");
  const auto r = testing::RunGonio(Fit(huge.string(), out));
  ExpectOneLineError(r, "huge.csv", "beyond what a fit can square");
  EXPECT_EQ(r.out.find("inf"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(out));
}

// Observations extracted with --assume-linear: the assumption travels in observations.csv and
// gonio fit reports it (fit.json "assumptions", ASSUMED: on the console), as gonio run does.
TEST_F(FitChecksCli, TheExtractionsAssumptionReachesFitJson) {
  testing::TempDir work;
  const fs::path s = work.path() / "s";
  fs::copy(Dir("a"), s, fs::copy_options::recursive);
  fs::remove(s / "photometric.json");
  Extract(s, "--assume-linear");
  const fs::path out = work.path() / "fit.json";
  const auto r = testing::RunGonio(Fit((s / "obs.csv").string(), out));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("ASSUMED: no photometric calibration"), std::string::npos) << r.out;
  const nlohmann::json fit = ReadJsonFile(out);
  // The linear camera, then the noise floor no calibration stated (pipeline/checks.h
  // AssumedNoiseFloorNote); `--noise-floor` names itself as the source.
  ASSERT_EQ(fit["assumptions"].size(), 2u) << fit["assumptions"];
  EXPECT_NE(fit["assumptions"][0].get<std::string>().find("linear camera"), std::string::npos);
  EXPECT_NE(fit["assumptions"][1].get<std::string>().find("1.00% (the default"), std::string::npos);
  const auto floored =
      testing::RunGonio(Fit((s / "obs.csv").string(), out) + " --noise-floor 0.005");
  ASSERT_EQ(floored.exit_code, 0) << floored.err;
  const nlohmann::json with_option = ReadJsonFile(out);
  ASSERT_EQ(with_option["assumptions"].size(), 2u) << with_option["assumptions"];
  EXPECT_NE(with_option["assumptions"][1].get<std::string>().find("0.50% (--noise-floor)"),
            std::string::npos);
}

// Output names: one the system cannot create (a 300-character name, a 5000-character path) is
// refused before the fit naming --out; one that is not UTF-8 is written (its bytes replaced in
// fit.json's text, not an exception).
TEST_F(FitChecksCli, OutputNamesAreCheckedBeforeTheWork) {
  testing::TempDir work;
  const std::string obs = Observations("a").string();
  ExpectOneLineError(testing::RunGonio(Fit(obs, work.path() / (std::string(300, 'n') + ".json"))),
                     "--out", "characters");
  fs::path deep = work.path();
  for (int k = 0; k < 25; ++k) deep /= std::string(200, 'd');
  ExpectOneLineError(testing::RunGonio(Fit(obs, deep / "fit.json")), "--out", "characters");
  const fs::path latin1 = work.path() / "r\xe9sultat.json";  // ISO 8859-1, not UTF-8
  const auto r = testing::RunGonio(Fit(obs, latin1, "lambert"));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_TRUE(fs::exists(latin1));
  EXPECT_NO_THROW(ReadJsonFile(latin1));
}

}  // namespace
}  // namespace gonio
