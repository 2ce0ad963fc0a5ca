// `gonio bench --tags`: gonio's tag detection against libapriltag alone (bench/bench_tags.h).
#include "bench/bench_tags.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <fstream>
#include <functional>
#include <map>
#include <sstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include "bench/bench_internal.h"
#include "calib/geometry/board.h"
#include "calib/geometry/detect.h"
#include "common/camera_model.h"
#include "common/error.h"
#include "common/geometry.h"
#include "common/io.h"
#include "common/math.h"
#include "common/session_frames.h"
#include "common/stats.h"
#include "data_synth/board_renderer.h"
#include "data_synth/scene.h"

namespace fs = std::filesystem;

namespace gonio::bench {
namespace {

// One image with what is there to find: per tag id its four corners (libapriltag's order,
// gonio's pixel convention).
struct TruthImage {
  std::string name;
  cv::Mat grey;
  const Board* board = nullptr;  // rendered scenes; nullptr for the photos
  std::string family = "tag36h11";
  std::vector<std::pair<int, std::array<Eigen::Vector2d, 4>>> tags;
  // Whether each tag lies wholly inside the image (to be found); tags cut by the border are
  // listed so that their detections are not counted as false.
  std::vector<bool> present;
};

struct Detector {
  std::string name;
  // Detected tags (id, corners) of an image.
  std::function<std::vector<TagDetection>(const TruthImage&)> run;
  bool libapriltag_alone = true;  // a row gonio's "found beyond libapriltag" is counted against
};

std::vector<TagDetection> FromBoardObservation(const BoardObservation& obs) {
  std::vector<TagDetection> out;
  for (size_t t = 0; t < obs.tag_ids.size(); ++t) {
    TagDetection d;
    d.id = obs.tag_ids[t];
    for (int c = 0; c < 4; ++c) d.corners[c] = obs.pixels[4 * t + c];
    out.push_back(d);
  }
  return out;
}

// With `boards` (the rendered scenes), gonio without its board too: `gonio detect --family`
// on the same images (on AprilTag's photos, which have no board, that is the "gonio" row).
std::vector<Detector> Detectors(bool boards) {
  auto libapriltag = [](double decimate, bool refine) {
    return [decimate, refine](const TruthImage& im) {
      AprilTagOptions o;
      o.family = im.family;
      o.decimate = decimate;
      o.refine_edges = refine;
      o.full_resolution_search = false;
      return DetectAprilTags(im.grey, o);
    };
  };
  std::vector<Detector> out = {
      {"gonio",
       [](const TruthImage& im) {
         AprilTagOptions o;
         o.family = im.family;
         if (im.board) return FromBoardObservation(DetectBoard(im.grey, *im.board, o, im.name));
         return DetectAprilTags(im.grey, o);
       },
       false},
      {"libapriltag d=2", libapriltag(2, true)},
      {"libapriltag d=1", libapriltag(1, true)},
      {"libapriltag d=1, no edge refinement", libapriltag(1, false)}};
  if (boards) {
    out.push_back({"gonio, no board",
                   [](const TruthImage& im) {
                     AprilTagOptions o;
                     o.family = im.family;
                     return DetectAprilTags(im.grey, o);
                   },
                   false});
  }
  return out;
}

// The tags of a rendered session that lie wholly inside each frame, from truth.json.
std::vector<TruthImage> RenderedImages(const fs::path& dir, const Board& board) {
  const Session session = ReadSession(dir);
  const nlohmann::json truth = ReadJsonFile(dir / "truth.json");
  const CameraModel camera = CameraModel::Read(dir / "camera.cameramodel");
  std::vector<TruthImage> out;
  ImageExpectation expect;
  expect.bit_depth = session.bit_depth;
  SessionFrames(session, expect).ForEach("read", [&](size_t f, const cv::Mat& raw) {
    TruthImage im;
    im.name = (dir.filename() / session.frames[f].file).string();
    im.board = &board;
    im.family = board.family();
    im.grey = GreyForDetection(raw, session.bit_depth);
    const Rigid3d cam_from_board = RigidFromJson(truth.at("frames").at(f).at("cam_from_board"));
    for (size_t k = 0; k < board.ids().size(); ++k) {
      if (board.ids()[k] < 0) continue;
      std::array<Eigen::Vector2d, 4> corners;
      bool inside = true, p_behind = false;
      for (int c = 0; c < 4; ++c) {
        const Eigen::Vector3d p = cam_from_board * board.Points()[Board::TagPointIndex(k, c)];
        if (p.z() <= 0) p_behind = true;
        corners[c] = camera.Project(p);
        inside = inside && corners[c].x() >= 1 && corners[c].y() >= 1 &&
                 corners[c].x() <= camera.width - 2 && corners[c].y() <= camera.height - 2;
      }
      if (p_behind) continue;
      im.tags.push_back({board.ids()[k], corners});
      im.present.push_back(inside);
    }
    out.push_back(std::move(im));
  });
  return out;
}

// AprilTag's test photos with their reference corners (libapriltag's pixel convention, so
// 0.5 px is subtracted: docs/conventions.md).
std::vector<TruthImage> ReferencePhotos(const fs::path& dir) {
  std::vector<TruthImage> out;
  for (const char* stem :
       {"33369213973_9d9bb4cc96_c", "34085369442_304b6bafd9_c", "34139872896_defdb2f8d9_c"}) {
    TruthImage im;
    im.name = std::string(stem) + ".jpg";
    im.grey = ReadGreyImage(dir / im.name);
    std::ifstream in(dir / (std::string(stem) + ".txt"));
    std::string line;
    while (std::getline(in, line)) {
      int id = 0;
      double p[8];
      if (std::sscanf(line.c_str(), "%d, (%lf %lf), (%lf %lf), (%lf %lf), (%lf %lf)", &id, &p[0],
                      &p[1], &p[2], &p[3], &p[4], &p[5], &p[6], &p[7]) != 9) {
        continue;
      }
      std::array<Eigen::Vector2d, 4> corners;
      for (int c = 0; c < 4; ++c) corners[c] = {p[2 * c] - 0.5, p[2 * c + 1] - 0.5};
      im.tags.push_back({id, corners});
      im.present.push_back(true);
    }
    out.push_back(std::move(im));
  }
  return out;
}

// Matches detections to the truth: same id, every corner within a quarter of the tag's edge.
// `matched`: per truth tag present, the corner errors of the detection matched to it (empty:
// not found).
void Score(const TruthImage& im, const std::vector<TagDetection>& found, bool reference,
           TagBenchRow* row, std::vector<double>* errors,
           std::vector<std::vector<double>>* matched) {
  matched->assign(im.tags.size(), {});
  std::vector<bool> taken(im.tags.size(), false);
  row->present += static_cast<int>(std::count(im.present.begin(), im.present.end(), true));
  for (const TagDetection& d : found) {
    int best = -1;
    double best_err = 0;
    for (size_t k = 0; k < im.tags.size(); ++k) {
      if (taken[k] || im.tags[k].first != d.id) continue;
      const auto& t = im.tags[k].second;
      const double edge = (t[0] - t[1]).norm();
      double err = 0;
      for (int c = 0; c < 4; ++c) err = std::max(err, (d.corners[c] - t[c]).norm());
      if (err <= std::max(2.0, 0.25 * edge) && (best < 0 || err < best_err)) {
        best = static_cast<int>(k);
        best_err = err;
      }
    }
    if (best < 0) {
      ++row->false_detections;
      continue;
    }
    taken[best] = true;
    if (!im.present[best]) continue;  // cut by the image border: neither found nor false
    ++row->found;
    double worst_coordinate = 0;
    for (int c = 0; c < 4; ++c) {
      const Eigen::Vector2d e = d.corners[c] - im.tags[best].second[c];
      errors->push_back(e.norm());
      (*matched)[best].push_back(e.norm());
      worst_coordinate = std::max({worst_coordinate, std::abs(e.x()), std::abs(e.y())});
    }
    if (reference && worst_coordinate <= 0.1) ++row->within_reference_tolerance;
  }
}

std::vector<TagBenchRow> MeasureScene(const std::string& scene, const std::vector<TruthImage>& ims,
                                      int repeats, bool reference) {
  const std::vector<Detector> detectors = Detectors(!reference);
  std::vector<TagBenchRow> rows(detectors.size());
  std::vector<std::vector<double>> errors(detectors.size());
  std::vector<double> beyond;  // corner errors of the tags only gonio (detector 0) finds
  for (size_t d = 0; d < detectors.size(); ++d) {
    rows[d].scene = scene;
    rows[d].detector = detectors[d].name;
    rows[d].images = static_cast<int>(ims.size());
  }
  for (const TruthImage& im : ims) {
    std::vector<double> best(detectors.size(), INFINITY);
    std::vector<std::vector<TagDetection>> found(detectors.size());
    // Interleaved: every detector once per round, so load changes hit them alike.
    for (int r = 0; r < repeats; ++r) {
      for (size_t d = 0; d < detectors.size(); ++d) {
        const auto start = std::chrono::steady_clock::now();
        found[d] = detectors[d].run(im);
        best[d] = std::min(best[d], SecondsSince(start));
      }
    }
    std::vector<std::vector<std::vector<double>>> matched(detectors.size());
    for (size_t d = 0; d < detectors.size(); ++d) {
      rows[d].seconds += best[d];
      Score(im, found[d], reference, &rows[d], &errors[d], &matched[d]);
    }
    for (size_t k = 0; k < im.tags.size(); ++k) {
      bool alone = !matched[0][k].empty();
      for (size_t d = 1; d < detectors.size(); ++d) {
        if (detectors[d].libapriltag_alone) alone = alone && matched[d][k].empty();
      }
      if (!alone) continue;
      ++rows[0].found_beyond_libapriltag;
      beyond.insert(beyond.end(), matched[0][k].begin(), matched[0][k].end());
    }
  }
  for (size_t d = 0; d < detectors.size(); ++d) {
    if (errors[d].empty()) continue;
    rows[d].median_corner_error_px = Median(errors[d]);
    rows[d].max_corner_error_px = *std::max_element(errors[d].begin(), errors[d].end());
  }
  if (!beyond.empty()) {
    rows[0].beyond_median_corner_error_px = Median(beyond);
    rows[0].beyond_max_corner_error_px = *std::max_element(beyond.begin(), beyond.end());
  }
  return rows;
}

// A full grid of tags seen from steep angles (60-80 deg off the board's normal) from 0.45 m and
// from 0.3 m: far, the foreshortened tags are too thin for a decimated search; near, they are
// large and steep, and the full-resolution search loses some the decimated one finds.
std::vector<synth::Scene> ObliqueScenes(const std::string& size) {
  synth::Scene s = synth::PresetScene("default");
  s.material = {"lambert", {{"albedo", 0.5}}};
  s.board.columns = 10;
  s.board.rows = 8;
  s.board.tag_size = 0.03;
  s.board.pitch = 0.0375;  // the renderer's least: one white bit cell between tags
  s.board.ids.clear();
  for (int k = 0; k < 80; ++k) s.board.ids.push_back(k);
  // The regions are required by the format; parked outside every view.
  s.board.sample_region = {-1.95, -1.95, -1.9, -1.9};
  s.board.white_region = {-1.5, -1.5, -1.45, -1.45};
  s.views.target = {0.184, 0.146, 0.0};  // the grid's centre
  s.views.rings_deg = size == "full"    ? std::vector<double>{60, 67, 74, 80}
                      : size == "quick" ? std::vector<double>{65, 75}
                                        : std::vector<double>{72};
  s.views.per_ring = size == "smoke" ? 2 : 4;
  s.views.roll_deg = 5;
  std::vector<synth::Scene> out;
  for (double distance : {0.45, 0.3}) {
    s.views.distance = distance;
    out.push_back(s);
  }
  return out;
}

synth::Scene SessionScene(const std::string& size) {
  synth::Scene s = synth::PresetScene("default");
  if (size == "quick") s.views.per_ring = 2;
  if (size == "smoke") {
    s.views.rings_deg = {15, 48};
    s.views.per_ring = 1;
  }
  return s;
}

}  // namespace

nlohmann::json TagBenchRow::ToJson() const {
  return {{"scene", scene},
          {"detector", detector},
          {"images", images},
          {"present", present},
          {"found", found},
          {"recall", recall()},
          {"false_detections", false_detections},
          {"median_corner_error_px", median_corner_error_px},
          {"max_corner_error_px", max_corner_error_px},
          {"within_reference_tolerance", within_reference_tolerance},
          {"found_beyond_libapriltag", found_beyond_libapriltag},
          {"beyond_median_corner_error_px", beyond_median_corner_error_px},
          {"beyond_max_corner_error_px", beyond_max_corner_error_px},
          {"seconds", seconds}};
}

nlohmann::json TagBenchReport::ToJson() const {
  nlohmann::json r = nlohmann::json::array();
  for (const auto& row : rows) r.push_back(row.ToJson());
  return {{"size", size}, {"rows", r}, {"time_ratios", ratios}};
}

fs::path DefaultAprilTagRefDir() { return fs::path(GONIO_SHARED_DATA_DIR) / "apriltag_ref"; }

TagBenchReport RunTagBench(const BenchOptions& options, const fs::path& work,
                           const fs::path& apriltag_ref) {
  options.Check();
  TagBenchReport rep;
  rep.size = options.size;
  const int repeats = options.size == "full" ? 3 : options.size == "quick" ? 2 : 1;
  const std::vector<std::pair<std::string, std::vector<synth::Scene>>> scenes = {
      {"session", {SessionScene(options.size)}}, {"oblique", ObliqueScenes(options.size)}};
  for (const auto& [name, parts] : scenes) {
    std::vector<Board> boards;  // one per part, alive while the images point at them
    boards.reserve(parts.size());
    std::vector<TruthImage> images;
    for (size_t p = 0; p < parts.size(); ++p) {
      const fs::path dir = work / fmt::format("{}-{}", name, p);
      spdlog::info("bench tags: rendering {} ({} views)", dir.filename().string(),
                   parts[p].CamFromBoardPoses().size());
      synth::RenderBoardSession(parts[p], dir, options.threads);
      boards.push_back(Board::Read(dir / "board.json"));
      for (auto& im : RenderedImages(dir, boards.back())) images.push_back(std::move(im));
    }
    const auto rows = MeasureScene(name, images, repeats, false);
    rep.rows.insert(rep.rows.end(), rows.begin(), rows.end());
  }
  const fs::path& ref = apriltag_ref;
  if (fs::exists(ref)) {
    const auto rows = MeasureScene("apriltag_ref", ReferencePhotos(ref), repeats, true);
    rep.rows.insert(rep.rows.end(), rows.begin(), rows.end());
  } else {
    spdlog::warn("bench tags: {} not found; AprilTag's photos skipped", ref.string());
  }
  std::map<std::string, std::map<std::string, double>> time;
  for (const auto& r : rep.rows) time[r.scene][r.detector] = r.seconds;
  for (auto& [scene, t] : time) {
    rep.ratios[scene] = {{"gonio_over_libapriltag_d2", t["gonio"] / t["libapriltag d=2"]},
                         {"gonio_over_libapriltag_d1", t["gonio"] / t["libapriltag d=1"]}};
  }
  return rep;
}

void WriteTagBenchOutputs(const fs::path& dir, const TagBenchReport& rep) {
  EnsureDirectory(dir);
  WriteJsonAtomically(dir / "tags_bench.json", rep.ToJson());
  PlotSpec spec;
  spec.title = "Tag detection: recall against time, same images";
  spec.xlabel = "detection time per image (ms)";
  spec.ylabel = "recall (tags found / tags present)";
  std::map<std::string, PlotSeries> by_detector;
  for (const auto& r : rep.rows) {
    PlotSeries& s = by_detector[r.detector];
    s.label = r.detector;
    s.style = "points pt 7 ps 1.4";
    s.x.push_back(1000 * r.seconds / std::max(r.images, 1));
    s.y.push_back(r.recall());
  }
  for (auto& [name, s] : by_detector) spec.series.push_back(s);
  spec.log_x = true;
  spec.extra = "set key bottom right\nset yrange [0:1.05]\n";
  RenderBoth(spec, dir / "tags_recall");
}

}  // namespace gonio::bench
