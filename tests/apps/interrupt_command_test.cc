// Interrupts (docs/pipeline.md "Checks", common/interrupt.h): SIGINT or SIGTERM while a
// command's temporary output exists leaves nothing behind and the previous output as it was,
// for run, extract, sfs and capture. GONIO_TEST_HOLD_TEMPORARIES=1 makes the command hold its
// first temporary (announced on stderr) until the signal comes, so the signal always arrives
// while the temporary exists, whatever the machine's load.
#include <csignal>
#include <fstream>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "common/io.h"
#include "common/math.h"
#include "data_synth/board_renderer.h"
#include "tests/pipeline/pipeline_test_util.h"
#include "tests/test_util.h"

namespace gonio {
namespace {

namespace fs = std::filesystem;

struct Interrupted {
  int status = -1;      // the shell's $?: 128 + signal when the signal ended it
  bool held = false;    // the command announced its temporary before the signal
  std::string log;      // its stderr
  std::string listing;  // the output folder's entries after it ended
};

// Runs `gonio ARGS` holding its first temporary, sends `signal` once the temporary is
// announced (at most 120 s), waits for the command to end, and lists `folder`.
Interrupted RunAndInterrupt(const std::string& args, const fs::path& folder, int signal,
                            const fs::path& work) {
  const fs::path log = work / "log.txt", status = work / "status.txt";
  const std::string script = fmt::format(
      "GONIO_TEST_HOLD_TEMPORARIES=1 {} {} 2>{} & pid=$!; "
      "for i in $(seq 1200); do grep -q 'holding temporary' {} && break; sleep 0.1; done; "
      "kill -{} $pid; wait $pid; echo $? > {}",
      testing::GonioBinary(), args, log.string(), log.string(), signal, status.string());
  Interrupted r;
  if (std::system(script.c_str()) != 0) return r;
  r.status = std::stoi(ReadTextFile(status));
  r.log = ReadTextFile(log);
  r.held = r.log.find("holding temporary") != std::string::npos;
  for (const auto& e : fs::directory_iterator(folder))
    r.listing += e.path().filename().string() + "\n";
  return r;
}

// Ended by the signal while its temporary existed, and nothing of it is left in `folder`.
void ExpectInterruptedCleanly(const Interrupted& r, int signal) {
  EXPECT_TRUE(r.held) << r.log;
  EXPECT_EQ(r.status, 128 + signal) << r.log;
  EXPECT_EQ(r.listing.find(".gonio-"), std::string::npos) << r.listing;
}

class InterruptCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new testing::TempDir;
    synth::Scene scene = SmallScene("lambert", {{"albedo", 0.6}});
    scene.views.rings_deg = {20, 45};
    scene.views.per_ring = 2;
    synth::RenderBoardSession(scene, Session(), 0);
    WriteTruePhotometric(Session());
  }
  static void TearDownTestSuite() { delete dir_; }
  static fs::path Session() { return dir_->path() / "session"; }
  static std::string Run(const fs::path& out) {
    return fmt::format("run --session {} --out {} --models lambert --white-albedo 0.8",
                       Session().string(), out.string());
  }
  static testing::TempDir* dir_;
};
testing::TempDir* InterruptCli::dir_ = nullptr;

// gonio run over a previous run: SIGINT and SIGTERM while the new output folder is being
// written; the previous run's folder stays as it was.
TEST_F(InterruptCli, RunKeepsThePreviousRun) {
  testing::TempDir work;
  const fs::path out = work.path() / "result";
  ASSERT_EQ(testing::RunGonio(Run(out)).exit_code, 0);
  const std::string fit_before = ReadTextFile(out / "fit.json");
  for (const int signal : {SIGINT, SIGTERM}) {
    const Interrupted r = RunAndInterrupt(Run(out), work.path(), signal, work.path());
    ExpectInterruptedCleanly(r, signal);
    EXPECT_EQ(ReadTextFile(out / "fit.json"), fit_before);
    EXPECT_TRUE(fs::exists(out / "report" / "index.html"));
  }
}

// SIGINT during the fit, before any temporary exists: nothing to remove, the process ends at
// once as without a handler (the watcher thread sees no temporary), and nothing is left.
TEST_F(InterruptCli, RunInterruptedDuringTheFitEndsAtOnce) {
  testing::TempDir work;
  const fs::path out = work.path() / "out", log = work.path() / "log.txt";
  const std::string script = fmt::format(
      "{} {} 2>{} & pid=$!; "
      "for i in $(seq 600); do grep -q 'fitting' {} && break; sleep 0.1; done; "
      "kill -INT $pid; wait $pid; echo $? > {}",
      testing::GonioBinary(), Run(out), log.string(), log.string(),
      (work.path() / "status.txt").string());
  ASSERT_EQ(std::system(script.c_str()), 0);
  EXPECT_NE(ReadTextFile(log).find("fitting"), std::string::npos);
  EXPECT_EQ(ReadTextFile(work.path() / "status.txt"), "130\n");
  EXPECT_FALSE(fs::exists(out));
  for (const auto& e : fs::directory_iterator(work.path())) {
    EXPECT_EQ(e.path().filename().string().rfind(".gonio-", 0), std::string::npos) << e.path();
  }
}

// gonio extract over a previous observations.csv.
TEST_F(InterruptCli, ExtractKeepsThePreviousObservations) {
  testing::TempDir work;
  const fs::path poses = work.path() / "poses.json", obs = work.path() / "obs.csv";
  ASSERT_EQ(
      testing::RunGonio(fmt::format("locate --session {} --camera {} --out {}", Session().string(),
                                    (Session() / "camera.cameramodel").string(), poses.string()))
          .exit_code,
      0);
  WriteTextAtomically(obs, "previous observations\n");
  const Interrupted r = RunAndInterrupt(
      fmt::format("extract --session {} --camera {} --poses {} --out {}", Session().string(),
                  (Session() / "camera.cameramodel").string(), poses.string(), obs.string()),
      work.path(), SIGINT, work.path());
  ExpectInterruptedCleanly(r, SIGINT);
  EXPECT_EQ(ReadTextFile(obs), "previous observations\n");
}

// gonio sfs over a previous sfs output folder: it was left as an empty folder before.
TEST_F(InterruptCli, SfsKeepsThePreviousOutput) {
  testing::TempDir work;
  const fs::path in = work.path() / "sphere", out = work.path() / "sfs";
  ASSERT_EQ(testing::RunGonio("synth --preset sfs-sphere --out " + in.string()).exit_code, 0);
  fs::create_directories(out);
  WriteTextAtomically(out / "sfs.json", "{\"previous\": true}\n");
  const Interrupted r =
      RunAndInterrupt(fmt::format("sfs --input {} --out {} --levels 1 --max-iterations 2",
                                  in.string(), out.string()),
                      work.path(), SIGINT, work.path());
  ExpectInterruptedCleanly(r, SIGINT);
  EXPECT_EQ(ReadTextFile(out / "sfs.json"), "{\"previous\": true}\n");
  EXPECT_EQ(std::distance(fs::directory_iterator(out), fs::directory_iterator()), 1);
}

// gonio capture --from-folder: an interrupted import leaves no session at all (a capture never
// replaces a folder, so there is no previous output to keep).
TEST_F(InterruptCli, CaptureLeavesNoPartialSession) {
  testing::TempDir work;
  const fs::path photos = work.path() / "photos", out = work.path() / "session";
  fs::create_directories(photos);
  std::ofstream list(photos / "list.txt");
  for (int k = 0; k < 3; ++k) {
    const std::string name = fmt::format("p{}.png", k);
    ASSERT_TRUE(
        cv::imwrite((photos / name).string(), cv::Mat(24, 32, CV_8UC1, cv::Scalar(40 * k))));
    list << name << " " << 0.01 * (k + 1) << "\n";
  }
  list.close();
  const Interrupted r =
      RunAndInterrupt(fmt::format("capture --from-folder {} --exposures-from {} --out {}",
                                  photos.string(), (photos / "list.txt").string(), out.string()),
                      work.path(), SIGINT, work.path());
  ExpectInterruptedCleanly(r, SIGINT);
  EXPECT_FALSE(fs::exists(out));
}

}  // namespace
}  // namespace gonio
