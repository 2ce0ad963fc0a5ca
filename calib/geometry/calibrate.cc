#include "calib/geometry/calibrate.h"

#include <sys/wait.h>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <Eigen/Eigenvalues>
#include <opencv2/calib3d.hpp>

#include "common/error.h"
#include "common/io.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

// mrcal's solve, through its Python API (python3-mrcal), staged as mrcal-calibrate-cameras
// stages its final solves: everything but the board warp, then everything, with mrcal's
// regularization and outlier rejection. The seed (intrinsics and board poses) comes from
// OpenCV's solve of the same corners. argv: problem.json, output .cameramodel. Prints one
// JSON line of statistics read back from the solved problem.
constexpr const char* kMrcalSolveScript = R"PY(
import json, sys
import numpy as np
import mrcal
d = json.load(open(sys.argv[1]))
N = len(d["frames_rt_toref"])
indices = np.zeros((N, 3), dtype=np.int32)
indices[:, 0] = np.arange(N)
indices[:, 2] = -1  # camera 0 is the reference frame
oi = dict(intrinsics=np.array([d["intrinsics"]], dtype=float),
          extrinsics_rt_fromref=np.zeros((0, 6), dtype=float),
          frames_rt_toref=np.array(d["frames_rt_toref"], dtype=float),
          points=None,
          observations_board=np.array(d["observations"], dtype=float),
          indices_frame_camintrinsics_camextrinsics=indices,
          observations_point=None,
          indices_point_camintrinsics_camextrinsics=None,
          lensmodel=d["lensmodel"],
          imagersizes=np.array([d["imagersize"]], dtype=np.int32),
          calobject_warp=np.zeros((2,), dtype=float),
          do_optimize_intrinsics_core=True,
          do_optimize_intrinsics_distortions=d["lensmodel"] != "LENSMODEL_PINHOLE",
          do_optimize_extrinsics=True,  # no extrinsics (one camera); as the tool sets it
          do_optimize_frames=True,
          do_optimize_calobject_warp=False,
          calibration_object_spacing=d["spacing"],
          do_apply_outlier_rejection=d["reject_outliers"],
          do_apply_regularization=True,
          verbose=False)
mrcal.optimize(**oi)
oi["do_optimize_calobject_warp"] = True
mrcal.optimize(**oi)
m = mrcal.cameramodel(optimization_inputs=oi, icam_intrinsics=0)
m.write(sys.argv[2], note="gonio calibrate: mrcal.optimize seeded by cv::calibrateCamera")
r = mrcal.residuals_chessboard(oi)           # inliers only, shape (N, 2)
e = np.sqrt(np.sum(r * r, axis=-1))
W, H = d["imagersize"]
qx, qy = np.meshgrid(np.linspace(0, W - 1, 9), np.linspace(0, H - 1, 7))
q = np.stack((qx.ravel(), qy.ravel()), axis=-1)
q = np.vstack((np.array([[(W - 1) / 2.0, (H - 1) / 2.0]]), q))
v = mrcal.unproject(q, *m.intrinsics())
cov = mrcal.projection_uncertainty(v, model=m, atinfinity=True, what="covariance")
print(json.dumps({"n_inliers": int(np.sum(oi["observations_board"][..., 2] > 0)),
                  "rms_px": float(np.sqrt(np.mean(e * e))),
                  "worst_px": float(np.max(e)),
                  "calobject_warp": oi["calobject_warp"].tolist(),
                  "pixels": q.tolist(), "directions": v.tolist(),
                  "covariances": cov.tolist()}))
)PY";

std::string Quote(const std::string& s) {
  std::string q = "'";
  for (char c : s) q += (c == '\'') ? std::string("'\\''") : std::string(1, c);
  return q + "'";
}

// Runs a shell command, stdout to `out`, stderr to `log`; returns the exit status.
int RunLogged(const std::string& command, const fs::path& out, const fs::path& log) {
  WriteTextAtomically(log, "# " + command + "\n");
  const std::string full = command + " >" + Quote(out.string()) + " 2>>" + Quote(log.string());
  spdlog::debug("running: {}", full);
  const int status = std::system(full.c_str());
  return (status != -1 && WIFEXITED(status)) ? WEXITSTATUS(status) : -1;
}

std::string LastLine(const fs::path& file) {
  std::ifstream in(file);
  std::string line, last;
  while (std::getline(in, line)) {
    if (line.find_first_not_of(" \t\r") != std::string::npos) last = line;
  }
  return last;
}

class ScratchDir {
 public:
  ScratchDir() {
    path_ = fs::temp_directory_path() / fmt::format("gonio_calib_{}", std::random_device{}());
    fs::create_directories(path_);
  }
  ~ScratchDir() {
    if (std::getenv("GONIO_KEEP_SCRATCH")) return;  // debugging mrcal runs
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

struct CvSolve {
  cv::Mat K, dist, std_intrinsics;
  std::vector<cv::Mat> rvecs, tvecs;  // cam_from_board per view
  double rms_px = 0, worst_px = 0;
  int num_points = 0;
};

struct CvViews {
  std::vector<std::vector<cv::Point3f>> object;
  std::vector<std::vector<cv::Point2f>> image;
};

CvViews ToCv(const Board& board, const std::vector<BoardObservation>& views) {
  CvViews cv_views;
  for (const auto& v : views) {
    cv_views.object.emplace_back();
    cv_views.image.emplace_back();
    for (size_t i = 0; i < v.pixels.size(); ++i) {
      const auto& p = board.Points()[v.point_index[i]];
      cv_views.object.back().emplace_back(p.x(), p.y(), p.z());
      cv_views.image.back().emplace_back(v.pixels[i].x(), v.pixels[i].y());
    }
  }
  return cv_views;
}

// The problem kMrcalSolveScript reads: the lens model, imager, board spacing, the seed's
// intrinsics and board poses, and every view's corners on the board's lattice.
nlohmann::json MrcalProblem(const Board& board, const std::vector<BoardObservation>& views,
                            int width, int height, const CvSolve& seed,
                            const CalibrationOptions& options) {
  const Board::MrcalGrid grid = board.ToMrcalGrid();
  nlohmann::json problem = {{"lensmodel", LensModelName(options.lens_model)},
                            {"imagersize", {width, height}},
                            {"spacing", grid.spacing},
                            {"reject_outliers", options.reject_outliers}};
  std::vector<double> intrinsics = {seed.K.at<double>(0, 0), seed.K.at<double>(1, 1),
                                    seed.K.at<double>(0, 2), seed.K.at<double>(1, 2)};
  const int n_dist = CameraModel::NumIntrinsics(options.lens_model) - 4;
  for (int i = 0; i < n_dist; ++i) intrinsics.push_back(seed.dist.at<double>(i));
  problem["intrinsics"] = intrinsics;
  // observations_board: (views, height_n, width_n, 3) of (x, y, weight); weight -1 marks the
  // lattice points no corner sits on (and, later, mrcal's outliers).
  nlohmann::json observations = nlohmann::json::array();
  nlohmann::json frames = nlohmann::json::array();
  for (size_t v = 0; v < views.size(); ++v) {
    std::vector<std::array<double, 3>> flat(grid.width_n * grid.height_n, {-1.0, -1.0, -1.0});
    for (size_t i = 0; i < views[v].pixels.size(); ++i) {
      flat[grid.lattice_index[views[v].point_index[i]]] = {views[v].pixels[i].x(),
                                                           views[v].pixels[i].y(), 1.0};
    }
    nlohmann::json rows = nlohmann::json::array();
    for (int r = 0; r < grid.height_n; ++r) {
      nlohmann::json row = nlohmann::json::array();
      for (int c = 0; c < grid.width_n; ++c) row.push_back(flat[r * grid.width_n + c]);
      rows.push_back(row);
    }
    observations.push_back(rows);
    frames.push_back({seed.rvecs[v].at<double>(0), seed.rvecs[v].at<double>(1),
                      seed.rvecs[v].at<double>(2), seed.tvecs[v].at<double>(0),
                      seed.tvecs[v].at<double>(1), seed.tvecs[v].at<double>(2)});
  }
  problem["observations"] = observations;
  problem["frames_rt_toref"] = frames;
  return problem;
}

// Runs kMrcalSolveScript on `problem` in a scratch folder: the solved model into `result`
// (its text and the camera), and the statistics line the script prints returned.
nlohmann::json RunMrcalScript(const nlohmann::json& problem, const CalibrationOptions& options,
                              CalibrationResult* result) {
  ScratchDir scratch;
  const fs::path problem_file = scratch.path() / "problem.json";
  WriteTextAtomically(problem_file, problem.dump());
  const fs::path model = scratch.path() / "camera.cameramodel";
  const fs::path script = scratch.path() / "solve.py";
  WriteTextAtomically(script, kMrcalSolveScript);
  const fs::path stats_file = scratch.path() / "stats.json";
  const std::string command = fmt::format("{} {} {} {}", options.python, Quote(script.string()),
                                          Quote(problem_file.string()), Quote(model.string()));
  const fs::path log = scratch.path() / "mrcal.log";
  if (RunLogged(command, stats_file, log) != 0) {
    throw NumericalError("mrcal's solve failed: " + LastLine(log));
  }
  if (!fs::exists(model)) throw NumericalError("mrcal wrote no model");
  result->model_text = ReadTextFile(model);
  result->camera = CameraModel::Read(model);
  try {
    return nlohmann::json::parse(LastLine(stats_file));
  } catch (const nlohmann::json::exception&) {
    throw NumericalError("python3-mrcal printed no statistics: " + LastLine(stats_file));
  }
}

// The residuals and the projection uncertainty grid of the script's statistics into
// `result`; throws when the views do not constrain the lens model (the uncertainty is not
// finite, or over options.max_uncertainty_px at the imager centre).
void ReadMrcalStats(const nlohmann::json& stats, const CalibrationOptions& options,
                    CalibrationResult* result) {
  result->rms_px = stats.at("rms_px");
  result->worst_px = stats.at("worst_px");
  result->num_outliers = result->num_points - stats.at("n_inliers").get<int>();
  try {
    for (size_t i = 0; i < stats.at("pixels").size(); ++i) {
      ProjectionUncertainty u;
      u.pixel = Eigen::Vector2d(stats["pixels"][i][0], stats["pixels"][i][1]);
      for (int k = 0; k < 3; ++k) u.direction[k] = stats["directions"][i][k];
      for (int r = 0; r < 2; ++r) {
        for (int c = 0; c < 2; ++c) u.covariance(r, c) = stats["covariances"][i][r][c];
      }
      result->uncertainty_grid.push_back(u);
    }
  } catch (const nlohmann::json::exception& e) {
    throw NumericalError(std::string("python3-mrcal gave malformed uncertainties: ") + e.what());
  }
  for (size_t i = 0; i < result->uncertainty_grid.size(); ++i) {
    const double s = result->uncertainty_grid[i].WorstStdev();
    if (!std::isfinite(s)) {
      throw InputError(std::string("the board views cannot constrain ") +
                       LensModelName(options.lens_model) +
                       ": mrcal's projection uncertainty is not finite");
    }
    if (i == 0) result->uncertainty_centre_px = s;
    result->uncertainty_max_px = std::max(result->uncertainty_max_px, s);
  }
  if (!(result->uncertainty_centre_px <= options.max_uncertainty_px)) {
    throw InputError(fmt::format(
        "the board views cannot constrain {}: mrcal's projection uncertainty at the imager "
        "centre is {:.3g} px (limit {} px); add views that tilt the board and fill the image",
        LensModelName(options.lens_model), result->uncertainty_centre_px,
        options.max_uncertainty_px));
  }
}

void SolveMrcal(const Board& board, const std::vector<BoardObservation>& views, int width,
                int height, const CvSolve& seed, const CalibrationOptions& options,
                CalibrationResult* result) {
  const nlohmann::json problem = MrcalProblem(board, views, width, height, seed, options);
  const nlohmann::json stats = RunMrcalScript(problem, options, result);
  ReadMrcalStats(stats, options, result);
}

CvSolve RunOpenCv(const Board& board, const std::vector<BoardObservation>& views, int width,
                  int height, double focal_seed, const CalibrationOptions& options) {
  CvSolve out;
  const CvViews cv_views = ToCv(board, views);
  int flags = cv::CALIB_USE_INTRINSIC_GUESS;
  const LensModel lm = options.lens_model;
  if (lm == LensModel::kPinhole) {
    flags |= cv::CALIB_FIX_K1 | cv::CALIB_FIX_K2 | cv::CALIB_FIX_K3 | cv::CALIB_ZERO_TANGENT_DIST;
  } else if (lm == LensModel::kOpenCV4) {
    flags |= cv::CALIB_FIX_K3;
  } else if (lm == LensModel::kOpenCV8) {
    flags |= cv::CALIB_RATIONAL_MODEL;
  }
  if (options.fix_aspect_ratio) flags |= cv::CALIB_FIX_ASPECT_RATIO;
  out.K = (cv::Mat_<double>(3, 3) << focal_seed, 0, (width - 1) / 2.0, 0, focal_seed,
           (height - 1) / 2.0, 0, 0, 1);
  out.dist = cv::Mat::zeros(lm == LensModel::kOpenCV8 ? 8 : 5, 1, CV_64F);
  cv::Mat std_extrinsics, per_view;
  cv::calibrateCamera(
      cv_views.object, cv_views.image, cv::Size(width, height), out.K, out.dist, out.rvecs,
      out.tvecs, out.std_intrinsics, std_extrinsics, per_view, flags,
      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12));
  double sum2 = 0;
  for (size_t v = 0; v < views.size(); ++v) {
    std::vector<cv::Point2f> projected;
    cv::projectPoints(cv_views.object[v], out.rvecs[v], out.tvecs[v], out.K, out.dist, projected);
    for (size_t i = 0; i < projected.size(); ++i) {
      const double e = cv::norm(projected[i] - cv_views.image[v][i]);
      sum2 += e * e;
      out.worst_px = std::max(out.worst_px, e);
      ++out.num_points;
    }
  }
  out.rms_px = std::sqrt(sum2 / std::max(1, out.num_points));
  return out;
}

void SolveOpenCv(const CvSolve& cv_solve, int width, int height, const CalibrationOptions& options,
                 CalibrationResult* result) {
  const LensModel lm = options.lens_model;
  CameraModel& cam = result->camera;
  cam.lens_model = lm;
  cam.width = width;
  cam.height = height;
  const cv::Mat& K = cv_solve.K;
  cam.intrinsics = {K.at<double>(0, 0), K.at<double>(1, 1), K.at<double>(0, 2), K.at<double>(1, 2)};
  const int n_dist = CameraModel::NumIntrinsics(lm) - 4;
  for (int i = 0; i < n_dist; ++i) cam.intrinsics.push_back(cv_solve.dist.at<double>(i));
  // OpenCV orders stdDeviationsIntrinsics fx, fy, cx, cy, k1, k2, p1, p2, k3, k4, k5, k6...
  for (int i = 0; i < 4 + n_dist; ++i) {
    result->intrinsics_sigma.push_back(cv_solve.std_intrinsics.at<double>(i));
  }
  // With CALIB_FIX_ASPECT_RATIO OpenCV reports sigma 0 for fx (it follows fy).
  if (options.fix_aspect_ratio) result->intrinsics_sigma[0] = result->intrinsics_sigma[1];
  result->rms_px = cv_solve.rms_px;
  result->worst_px = cv_solve.worst_px;
  const double f_sigma_px = std::max(result->intrinsics_sigma[0], result->intrinsics_sigma[1]);
  if (!std::isfinite(f_sigma_px) || f_sigma_px > options.max_uncertainty_px * 10 ||
      !std::isfinite(result->rms_px) || !cam.IntrinsicsFinite()) {
    throw InputError(
        fmt::format("the board views cannot constrain {}: OpenCV's focal sigma is "
                    "{:.3g} px; add views that tilt the board and fill the image",
                    LensModelName(lm), f_sigma_px));
  }
}

}  // namespace

double ProjectionUncertainty::WorstStdev() const {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(covariance);
  return std::sqrt(std::max(0.0, eig.eigenvalues().maxCoeff()));
}

void CalibrationOptions::Check() const {
  if (solver != "mrcal" && solver != "opencv") {
    throw InputError("--solver must be 'mrcal' or 'opencv', not '" + solver + "'");
  }
  if (!(focal_seed_px >= 0) || !std::isfinite(focal_seed_px)) {
    throw InputError("--focal must be a positive number of pixels");
  }
  if (min_views < 1) throw InputError("min_views must be at least 1");
  if (!(max_uncertainty_px > 0)) throw InputError("max_uncertainty_px must be positive");
}

double EstimateFocalFromViews(const Board& board, const std::vector<BoardObservation>& views,
                              int width, int height) {
  std::vector<BoardObservation> usable;
  for (const auto& v : views) {
    if (v.pixels.size() >= 4) usable.push_back(v);
  }
  if (usable.empty()) throw InputError("no view has 4 board corners to estimate a focal length");
  const CvViews cv_views = ToCv(board, usable);
  const cv::Mat K =
      cv::initCameraMatrix2D(cv_views.object, cv_views.image, cv::Size(width, height), 1.0);
  const double f = K.at<double>(0, 0);
  if (!std::isfinite(f) || f <= 0) {
    throw InputError("the board views give no focal length (is the board seen face-on only?)");
  }
  return f;
}

CalibrationResult Calibrate(const Board& board, const std::vector<BoardObservation>& views,
                            int width, int height, const CalibrationOptions& options) {
  options.Check();
  if (width <= 0 || height <= 0) throw InputError("calibrate: unknown image size");
  CalibrationResult result;
  result.solver = options.solver;
  std::vector<BoardObservation> used;
  for (const auto& v : views) {
    if (v.pixels.size() < 4) {
      result.skipped_views.push_back(v.image + ": board not found (fewer than 4 corners)");
    } else {
      used.push_back(v);
      result.num_points += static_cast<int>(v.pixels.size());
    }
  }
  result.num_views = static_cast<int>(used.size());
  const int n_intrinsics = CameraModel::NumIntrinsics(options.lens_model);
  if (result.num_views < options.min_views) {
    throw InputError(fmt::format(
        "{} usable board view(s) cannot constrain {}: need at least {} views of the board at "
        "different orientations",
        result.num_views, LensModelName(options.lens_model), options.min_views));
  }
  if (2 * result.num_points < 2 * (n_intrinsics + 6 * result.num_views)) {
    throw InputError(
        fmt::format("{} corners in {} views cannot constrain {} intrinsics and the "
                    "board poses",
                    result.num_points, result.num_views, n_intrinsics));
  }
  const double focal = options.focal_seed_px > 0
                           ? options.focal_seed_px
                           : EstimateFocalFromViews(board, used, width, height);
  spdlog::info("calibrate: {} views, {} corners, {} with {} (focal seed {:.1f} px)",
               result.num_views, result.num_points, LensModelName(options.lens_model),
               options.solver, focal);
  // OpenCV's solve is the alternative solver's answer and also mrcal's seed: the seeding of
  // mrcal-calibrate-cameras 2.2 passes missing lattice points, stored at pixel (-1, -1), to
  // solvePnP as if detected, so AprilTag grids (89% missing) get a wrong seed
  // (docs/calibration.md).
  const CvSolve cv_solve = RunOpenCv(board, used, width, height, focal, options);
  if (options.solver == "mrcal") {
    SolveMrcal(board, used, width, height, cv_solve, options, &result);
  } else {
    SolveOpenCv(cv_solve, width, height, options, &result);
  }
  // Recorded with the model, so a session that does not fit it is recognised
  // (calib/geometry/locate.h).
  result.camera.calibration_rms_px = result.rms_px;
  return result;
}

nlohmann::json CalibrationResult::ToJson() const {
  nlohmann::json j = {{"solver", solver},
                      {"lens_model", LensModelName(camera.lens_model)},
                      {"intrinsics", camera.intrinsics},
                      {"imagersize", {camera.width, camera.height}},
                      {"views", num_views},
                      {"points", num_points},
                      {"rms_px", rms_px},
                      {"worst_px", worst_px},
                      {"outliers", num_outliers},
                      {"skipped_views", skipped_views}};
  if (solver == "mrcal") {
    j["projection_uncertainty_px"] = {{"centre", uncertainty_centre_px},
                                      {"max_over_imager", uncertainty_max_px},
                                      {"what", "1-sigma, worst direction, points at infinity"}};
  } else {
    j["intrinsics_sigma"] = intrinsics_sigma;
  }
  return j;
}

std::string CalibrationResult::Report() const {
  std::string s = fmt::format("{} {}: {} views, {} corners\n", solver,
                              LensModelName(camera.lens_model), num_views, num_points);
  s += fmt::format("  fx {:.3f}  fy {:.3f}  cx {:.3f}  cy {:.3f}\n", camera.intrinsics[0],
                   camera.intrinsics[1], camera.intrinsics[2], camera.intrinsics[3]);
  s += fmt::format("  RMS {:.4f} px, worst {:.3f} px, outliers {}\n", rms_px, worst_px,
                   num_outliers);
  if (solver == "mrcal") {
    s += fmt::format(
        "  projection uncertainty (1 sigma, at infinity): {:.3f} px at the centre, "
        "{:.3f} px worst over the imager\n",
        uncertainty_centre_px, uncertainty_max_px);
  } else {
    s += fmt::format("  sigma fx {:.3f} fy {:.3f} cx {:.3f} cy {:.3f} px\n", intrinsics_sigma[0],
                     intrinsics_sigma[1], intrinsics_sigma[2], intrinsics_sigma[3]);
  }
  for (const auto& v : skipped_views) s += "  skipped " + v + "\n";
  return s;
}

}  // namespace gonio
