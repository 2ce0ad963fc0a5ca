// `gonio plan` (docs/plan.md): the camera poses to photograph a sample from, chosen before the
// capture so the joint fit's material parameters and lamp come out as precisely as possible.
//
//   candidates   a grid of poses (polar angle, azimuth, distance) looking at the sample centre,
//                kept when the camera sees every tag and the whole sample region
//   prediction   per candidate, the observations `gonio run` would extract (the sample's 4x4
//                patches, subsampled and weighted), their radiance under the hypothesised
//                material and lamp, their noise from data_synth's sensor model; patches that
//                would saturate at the planned exposure are dropped, as the extraction drops
//                them. Their information for the joint fit comes from estimation/joint/design.h.
//   selection    N distinct poses minimising the predicted scatter covariance (D: its log
//                determinant, A: its trace, both range-scaled): greedy, then exchanges
//                (Fedorov) until no swap helps.
//   comparison   the default orbit of data_synth (scene.h) with the same number of views.
#pragma once

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <nlohmann/json.hpp>

#include "calib/geometry/board.h"
#include "common/camera_model.h"
#include "common/geometry.h"
#include "data_synth/scene.h"
#include "estimation/joint/design.h"
#include "estimation/joint/joint_fit.h"
#include "pipeline/run.h"

namespace gonio {

enum class DesignCriterion { kD, kA };
// "d" or "a"; InputError naming `option_name` otherwise.
DesignCriterion ParseDesignCriterion(const std::string& word, const std::string& option_name);
std::string ToString(DesignCriterion criterion);

struct PlanOptions {
  DesignHypothesis hypothesis;
  std::optional<double> white_albedo;  // the board's white reference; none: albedo x intensity
  int views = 12;
  DesignCriterion criterion = DesignCriterion::kD;
  // The candidate grid around the sample centre.
  std::vector<double> polar_deg = {0, 10, 20, 30, 40, 50, 60, 70};
  int azimuths = 12;
  std::vector<double> distances_m = {0.3, 0.38, 0.45, 0.55, 0.7};
  double min_lamp_clearance_m = 0.1;  // a camera no closer than this to a board-fixed lamp
  // Exposure and sensor: data_synth's pixel chain (scene.h PhotometricSpec).
  double exposure_s = 0.01;
  synth::PhotometricSpec sensor;
  // Patches whose brightest expected pixel exceeds this relative exposure are dropped (noise
  // would push some to the clip).
  double saturation_level = 0.9;
  ExtractOptions extract;          // patch size and edge margin, as gonio run extracts
  int max_patches_per_view = 300;  // the prediction's subsample of a view's patches
  JointFitOptions fit;             // noise floor, uncertainty rules, observation cap
  PlanOptions() { extract.patch = RunOptions().extract.patch; }
  void Check() const;  // InputError naming the option
};

struct PlannedView {
  Rigid3d cam_from_board;
  double polar_deg = 0, azimuth_deg = 0, distance_m = 0;
  size_t patches = 0;    // sample and white patches the camera would see (unsaturated)
  size_t saturated = 0;  // patches dropped as saturated
  DesignInformation information;
};

struct PlanResult {
  PlanOptions options;
  size_t candidates = 0;           // reachable candidate poses
  std::vector<PlannedView> plan;   // the chosen poses, in capture order
  std::vector<PlannedView> orbit;  // the default orbit of the same count
  PredictedUncertainty plan_prediction, orbit_prediction;
  double plan_criterion = 0, orbit_criterion = 0;  // lower is better
  std::string Report() const;
  nlohmann::json ToJson() const;  // plan.json (docs/plan.md)
};

// The information of one pose (its predicted observations); `view` gets the counts.
PlannedView PredictView(const Rigid3d& cam_from_board, const CameraModel& camera,
                        const Board& board, const PlanOptions& options);

// The prediction for a set of views: their information summed, scaled to the fit's observation
// cap (the fit subsamples to JointFitOptions::final_max_observations).
PredictedUncertainty PredictViews(const std::vector<PlannedView>& views,
                                  const PlanOptions& options);

// The default orbit (data_synth's ViewsSpec) thinned evenly to `count` poses.
std::vector<Rigid3d> DefaultOrbit(const Board& board, int count);

// Candidates, selection and the orbit comparison. InputError when no candidate pose sees the
// board and sample, or fewer than `views` do.
PlanResult MakePlan(const Board& board, const CameraModel& camera, const PlanOptions& options);

// OUT/plan.json, plan.csv, plan.png (the board from above with the cameras), coverage.png
// ((theta_i, theta_r, phi) of plan and orbit), written into a temporary folder and renamed.
void WritePlan(const PlanResult& plan, const Board& board, const CameraModel& camera,
               const std::filesystem::path& out);

// The poses of a plan.json; InputError naming the file.
std::vector<Rigid3d> ReadPlanPoses(const std::filesystem::path& path);

// How well the frames of a run match a plan: each planned pose's nearest frame (angle between
// the viewing directions, relative distance difference); a pose counts as covered within
// `max_angle_deg` and 15% of its distance.
struct PlanCoverage {
  std::vector<double> nearest_angle_deg, nearest_distance_ratio;
  size_t covered = 0;
  double max_angle_deg = 10;
  std::string Report() const;
  nlohmann::json ToJson() const;
};

// The coverage of `planned` by the located frames of a run, into result->plan_coverage(_report).
void AddPlanCoverage(const std::vector<Rigid3d>& planned, const Board& board, RunResult* result);

PlanCoverage CompareWithPlan(const std::vector<Rigid3d>& planned,
                             const std::vector<Rigid3d>& achieved, const Eigen::Vector3d& target,
                             double max_angle_deg = 10);

}  // namespace gonio
