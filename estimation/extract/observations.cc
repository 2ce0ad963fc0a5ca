#include "estimation/extract/observations.h"

#include <algorithm>
#include <array>
#include <climits>
#include <cmath>
#include <cstdio>
#include <sstream>

#include <fmt/format.h>

#include "common/csv.h"
#include "common/error.h"
#include "common/io.h"

namespace gonio {
namespace {

// Frame indices size the list of frame files: bounded so that a file cannot make the reader
// allocate without limit (no session comes near a million frames).
constexpr int kMaxFrameIndex = 1000000;

// A CSV cell that holds an integer in [lo, hi]; checked before the conversion to int, which
// is undefined for values out of range.
int IntegerCell(const CsvTable& csv, size_t row, size_t col, int lo, int hi,
                const std::string& path, const char* name) {
  const double v = csv.Number(row, col);
  if (!(v >= lo && v <= hi) || v != std::floor(v)) {
    throw InputError(fmt::format("{}: line {}: {} must be an integer in [{}, {}]", path,
                                 csv.LineOf(row), name, lo, hi));
  }
  return static_cast<int>(v);
}

// The patch's second moment (m^2): a covariance, so its diagonal is >= 0 and |xy| at most
// sqrt(xx yy); and far below a square metre.
void ReadPatchMoment(const CsvTable& csv, size_t row, const std::array<size_t, 3>& cols,
                     const std::string& path, Eigen::Matrix2d* m) {
  const double xx = csv.Number(row, cols[0]), xy = csv.Number(row, cols[1]),
               yy = csv.Number(row, cols[2]);
  if (!(xx >= 0 && yy >= 0 && xx < 1 && yy < 1 && xy * xy <= xx * yy * (1 + 1e-6) + 1e-30)) {
    throw InputError(
        fmt::format("{}: line {}: patch_xx, patch_xy, patch_yy are not a patch's "
                    "second moment (m^2)",
                    path, csv.LineOf(row)));
  }
  *m << xx, xy, xy, yy;
}

// A header line recording what the extraction assumed (ObservationSet::assumptions).
constexpr const char* kAssumption = "# assumption: ";

}  // namespace

void WriteObservations(const std::filesystem::path& path, const ObservationSet& set) {
  std::string out;
  out.reserve(set.observations.size() * 160 + 256);
  out += "# gonio observations: board-frame metres, linear relative radiance\n";
  for (const auto& a : set.assumptions) out += "# assumption: " + a + "\n";
  for (size_t f = 0; f < set.frame_files.size(); ++f) {
    out += fmt::format("# frame {} {}\n", f, set.frame_files[f]);
  }
  out += "frame,px,py,x,y,z,cam_x,cam_y,cam_z,aa_x,aa_y,aa_z,region,n,patch_xx,patch_xy,patch_yy";
  for (int c = 0; c < set.channels; ++c) out += fmt::format(",L{}", c);
  for (int c = 0; c < set.channels; ++c) out += fmt::format(",var{}", c);
  out += "\n";
  for (const auto& o : set.observations) {
    // No NaN or Inf reaches a file: extraction refuses them, so one here is a defect.
    bool finite =
        o.p_in_board.allFinite() && o.camera_in_board.allFinite() && o.patch_moment.allFinite();
    for (double v : o.radiance) finite = finite && std::isfinite(v);
    for (double v : o.variance) finite = finite && std::isfinite(v);
    if (!finite) {
      throw NumericalError(
          fmt::format("{}: observation of frame {} at ({:.1f}, {:.1f}) is not "
                      "finite; nothing written",
                      path.string(), o.frame, o.px, o.py));
    }
    out += fmt::format(
        "{},{:.2f},{:.2f},{:.7g},{:.7g},{:.7g},{:.7g},{:.7g},{:.7g},{:.9g},{:.9g},{:.9g},{},{},"
        "{:.6g},{:.6g},{:.6g}",
        o.frame, o.px, o.py, o.p_in_board.x(), o.p_in_board.y(), o.p_in_board.z(),
        o.camera_in_board.x(), o.camera_in_board.y(), o.camera_in_board.z(),
        o.board_from_cam_aa.x(), o.board_from_cam_aa.y(), o.board_from_cam_aa.z(),
        o.white ? "white" : "sample", o.num_pixels, o.patch_moment(0, 0), o.patch_moment(0, 1),
        o.patch_moment(1, 1));
    for (double v : o.radiance) out += fmt::format(",{:.7g}", v);
    for (double v : o.variance) out += fmt::format(",{:.7g}", v);
    out += "\n";
  }
  WriteTextAtomically(path, out);
}

ObservationSet ReadObservations(const std::filesystem::path& path) {
  const std::string text = ReadTextFile(path);
  ObservationSet set;
  {
    std::istringstream in(text);
    std::string line;
    for (int line_number = 1; std::getline(in, line) && !line.empty() && line[0] == '#';
         ++line_number) {
      int f;
      char name[4096];
      if (line.rfind(kAssumption, 0) == 0) {
        set.assumptions.push_back(line.substr(std::string(kAssumption).size()));
        continue;
      }
      if (std::sscanf(line.c_str(), "# frame %d %4095s", &f, name) == 2) {
        if (f < 0 || f > kMaxFrameIndex) {
          throw InputError(fmt::format("{}: line {}: frame index must be in [0, {}]", path.string(),
                                       line_number, kMaxFrameIndex));
        }
        if (f >= static_cast<int>(set.frame_files.size())) set.frame_files.resize(f + 1);
        set.frame_files[f] = name;
      }
    }
  }
  const CsvTable csv = CsvTable::Parse(text, path.string());
  const char* required[] = {"frame", "px",    "py",   "x",    "y",    "z",      "cam_x",
                            "cam_y", "cam_z", "aa_x", "aa_y", "aa_z", "region", "n"};
  std::vector<size_t> col;
  for (const char* r : required) col.push_back(csv.Require(r));
  set.channels = 0;
  while (csv.Find(fmt::format("L{}", set.channels))) ++set.channels;
  if (set.channels == 0) throw InputError(path.string() + ": missing column 'L0'");
  // The patch's second moment: optional (files written before it stay readable).
  const auto xx = csv.Find("patch_xx"), xy = csv.Find("patch_xy"), yy = csv.Find("patch_yy");
  if ((xx || xy || yy) && !(xx && xy && yy)) {
    throw InputError(path.string() + ": patch_xx, patch_xy and patch_yy go together");
  }
  std::vector<size_t> lc, vc;
  for (int c = 0; c < set.channels; ++c) {
    lc.push_back(csv.Require(fmt::format("L{}", c)));
    vc.push_back(csv.Require(fmt::format("var{}", c)));
  }
  for (size_t r = 0; r < csv.num_rows(); ++r) {
    Observation o;
    o.frame = IntegerCell(csv, r, col[0], 0, kMaxFrameIndex, path.string(), "frame");
    o.px = csv.Number(r, col[1]);
    o.py = csv.Number(r, col[2]);
    o.p_in_board = {csv.Number(r, col[3]), csv.Number(r, col[4]), csv.Number(r, col[5])};
    o.camera_in_board = {csv.Number(r, col[6]), csv.Number(r, col[7]), csv.Number(r, col[8])};
    o.board_from_cam_aa = {csv.Number(r, col[9]), csv.Number(r, col[10]), csv.Number(r, col[11])};
    const std::string& region = csv.Cell(r, col[12]);
    if (region != "sample" && region != "white") {
      throw InputError(
          fmt::format("{}: line {}: region must be sample or white", path.string(), csv.LineOf(r)));
    }
    o.white = region == "white";
    o.num_pixels = IntegerCell(csv, r, col[13], 1, INT_MAX, path.string(), "n");
    if (xx) ReadPatchMoment(csv, r, {*xx, *xy, *yy}, path.string(), &o.patch_moment);
    for (int c = 0; c < set.channels; ++c) {
      o.radiance.push_back(csv.Number(r, lc[c]));
      o.variance.push_back(csv.Number(r, vc[c]));
      if (o.variance.back() < 0) {
        throw InputError(
            fmt::format("{}: line {}: negative variance", path.string(), csv.LineOf(r)));
      }
    }
    if (o.frame >= static_cast<int>(set.frame_files.size())) set.frame_files.resize(o.frame + 1);
    set.observations.push_back(std::move(o));
  }
  if (set.observations.empty()) throw InputError(path.string() + ": no observations");
  return set;
}

std::vector<double> RawValuesOf(const ObservationSet& set) {
  std::vector<double> values;
  for (const auto& o : set.observations)
    values.insert(values.end(), o.value.begin(), o.value.end());
  return values;
}

ObservationSet MergeObservations(const std::vector<ObservationSet>& sets) {
  ObservationSet out;
  if (sets.empty()) return out;
  out.channels = sets[0].channels;
  for (const auto& s : sets) {
    if (s.channels != out.channels) {
      throw InputError("observation files have different channel counts");
    }
    const int offset = static_cast<int>(out.frame_files.size());
    out.frame_files.insert(out.frame_files.end(), s.frame_files.begin(), s.frame_files.end());
    for (auto o : s.observations) {
      o.frame += offset;
      out.observations.push_back(std::move(o));
    }
    out.excluded.insert(out.excluded.end(), s.excluded.begin(), s.excluded.end());
    out.lamp_off_frames += s.lamp_off_frames;
    for (const auto& a : s.assumptions) {
      if (std::find(out.assumptions.begin(), out.assumptions.end(), a) == out.assumptions.end()) {
        out.assumptions.push_back(a);
      }
    }
  }
  return out;
}

}  // namespace gonio
