// `gonio bench --tags` (docs/bench.md, docs/calibration.md "Tag detection"): gonio's AprilTag
// detection (a decimated pass, then full resolution where tags are missing) against libapriltag
// at decimation 1 and 2 alone, on the same images: recall, false detections, corner error and
// time.
//
// Scenes:
//  - "session": the default preset (gonio's own sessions: the board ring, 24 views);
//  - "oblique": a full 10 x 8 grid of tags rendered from steep angles (60-80 deg off the
//    board's normal), where foreshortened tags are lost at either decimation;
//  - "apriltag_ref": AprilTag's own three test photos (../shared/data/apriltag_ref, 47 tags)
//    with the reference corners its test suite checks (tolerance 0.1 px per coordinate).
// Rendered scenes are judged by the truth: the board's corners projected through the true
// camera and pose (truth.json), in gonio's pixel convention.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "bench/bench_lib.h"

namespace gonio::bench {

struct TagBenchRow {
  std::string scene, detector;  // detector: "gonio", "libapriltag d=1", "libapriltag d=2"
  int images = 0;
  int present = 0;           // tags the truth (or reference) says are there to find
  int found = 0;             // of those, detected with the right id
  int false_detections = 0;  // ids not there, or far from where the truth puts them
  double median_corner_error_px = 0, max_corner_error_px = 0;  // of the found tags
  // apriltag_ref only: found tags with every coordinate within 0.1 px of the reference.
  int within_reference_tolerance = 0;
  // gonio only: tags no libapriltag row finds on that image, and their corner errors.
  int found_beyond_libapriltag = 0;
  double beyond_median_corner_error_px = 0, beyond_max_corner_error_px = 0;
  double seconds = 0;  // detection only (images decoded beforehand), summed over the images
  double recall() const { return present > 0 ? static_cast<double>(found) / present : 0; }
  nlohmann::json ToJson() const;
};

struct TagBenchReport {
  std::string size;
  std::vector<TagBenchRow> rows;
  // Per scene: gonio's time over libapriltag d=2's (today's default) and d=1's, same run.
  nlohmann::json ratios;
  nlohmann::json ToJson() const;
};

// Where AprilTag's photos are by default: ../shared/data/apriltag_ref beside the source tree
// this binary was built from.
std::filesystem::path DefaultAprilTagRefDir();

// Renders the scenes into `work` and times every detector on the same decoded images,
// interleaved, best of several runs per image; AprilTag's photos are read from `apriltag_ref`
// (skipped with a warning when absent).
TagBenchReport RunTagBench(const BenchOptions& options, const std::filesystem::path& work,
                           const std::filesystem::path& apriltag_ref);

// tags_bench.json and tags_recall.{png,svg} (recall against time per scene).
void WriteTagBenchOutputs(const std::filesystem::path& dir, const TagBenchReport& rep);

}  // namespace gonio::bench
