// `gonio plan`'s outputs (plan.json, plan.csv, the two pictures) and the coverage a run
// achieved against a plan (pipeline/plan.h, docs/plan.md).
#include <unistd.h>

#include <algorithm>
#include <cmath>

#include <fmt/format.h>

#include "common/error.h"
#include "common/io.h"
#include "common/math.h"
#include "common/plot.h"
#include "pipeline/plan.h"
#include "reflectance/angles.h"

namespace fs = std::filesystem;

namespace gonio {
namespace {

nlohmann::json FiniteOrNull(double v) { return std::isfinite(v) ? nlohmann::json(v) : nullptr; }

nlohmann::json ViewJson(const PlannedView& v) {
  return {{"polar_deg", v.polar_deg},
          {"azimuth_deg", v.azimuth_deg},
          {"distance_m", v.distance_m},
          {"camera_in_board",
           {v.cam_from_board.Inverse().t.x(), v.cam_from_board.Inverse().t.y(),
            v.cam_from_board.Inverse().t.z()}},
          {"cam_from_board", ToJson(v.cam_from_board)},
          {"patches", v.patches},
          {"saturated_patches", v.saturated}};
}

// A number for the report, or what its absence means (never "inf" or "nan").
std::string Figure(double v, const char* otherwise) {
  return std::isfinite(v) ? fmt::format("{:.4g}", v) : std::string(otherwise);
}

// One line per parameter: predicted scatter and the fit's reported stddev, plan vs orbit.
std::string PredictionTable(const PredictedUncertainty& plan, const PredictedUncertainty& orbit) {
  std::string s = fmt::format("  {:<12} {:>14} {:>14} {:>14}\n", "parameter", "plan scatter",
                              "orbit scatter", "plan reported");
  for (size_t k = 0; k < plan.names.size(); ++k) {
    const int j = orbit.Index(plan.names[k]);
    const double o = j >= 0 ? orbit.scatter[j] : INFINITY;
    s += fmt::format("  {:<12} {:>14} {:>14} {:>14}\n", plan.names[k],
                     Figure(plan.scatter[k], "unseen"), Figure(o, "unseen"),
                     Figure(plan.reported[k].value_or(NAN), "undetermined"));
  }
  s += fmt::format("  {:<12} {:>14} {:>14}\n", "lamp (m)", Figure(plan.LampScatter(), "unseen"),
                   Figure(orbit.LampScatter(), "unseen"));
  return s;
}

// (theta_i, theta_r, phi) at board point `p` for a pose, radians.
Angles<double> AnglesAt(const PlannedView& v, const DesignHypothesis& h, const Eigen::Vector3d& p) {
  const Rigid3d board_from_cam = v.cam_from_board.Inverse();
  const Eigen::Vector3d lamp = h.lamp_frame == LampFrame::kBoard
                                   ? h.lamp
                                   : Eigen::Vector3d(board_from_cam.R * h.lamp + board_from_cam.t);
  const Eigen::Vector3d l = lamp - p, c = board_from_cam.t - p;
  const double ls[3] = {l.x(), -l.y(), -l.z()}, vs[3] = {c.x(), -c.y(), -c.z()};
  return AnglesFromDirections(ls, vs);
}

void PlotTopView(const PlanResult& r, const Board& board, const fs::path& out) {
  PlotSpec spec;
  spec.title =
      fmt::format("{} planned views: the board from above (camera height in m)", r.plan.size());
  spec.xlabel = "board x (m)";
  spec.ylabel = "board y (m)";
  spec.width = spec.height = 800;
  std::string e = "set size ratio -1\nset yrange [*:*] reverse\n";
  auto polygon = [&](const std::vector<Eigen::Vector2d>& poly, const std::string& style) {
    if (poly.size() < 3) return;
    e += "set object polygon from ";
    for (size_t i = 0; i <= poly.size(); ++i) {
      const auto& q = poly[i % poly.size()];
      e += fmt::format("{}{:.4f},{:.4f}", i ? " to " : "", q.x(), q.y());
    }
    e += " " + style + "\n";
  };
  polygon(board.sample_region(), "fc rgb '#c8a070' fs solid 0.5 border lc rgb '#806040'");
  polygon(board.white_region(), "fc rgb '#f0f0f0' fs solid 1 border lc rgb '#808080'");
  for (size_t k = 0; k < board.ids().size(); ++k) {
    if (board.ids()[k] < 0) continue;
    const Eigen::Vector3d& tl = board.Points()[Board::TagPointIndex(static_cast<int>(k), 3)];
    const double s = board.tag_size();
    polygon(
        {{tl.x(), tl.y()}, {tl.x() + s, tl.y()}, {tl.x() + s, tl.y() + s}, {tl.x(), tl.y() + s}},
        "fc rgb '#404040' fs solid 1 noborder");
  }
  e += "$cams << EOD\n";
  for (size_t i = 0; i < r.plan.size(); ++i) {
    const Eigen::Vector3d c = r.plan[i].cam_from_board.Inverse().t;
    // Arrow from the camera's foot point towards where it looks (the sample centre).
    const Eigen::Vector3d look = r.plan[i].cam_from_board.R.transpose().col(2);
    const double reach = look.head<2>().norm() > 1e-9 ? -c.z() / look.z() : 0.0;
    e += fmt::format("{:.4f} {:.4f} {:.4f} {:.4f} {} {:.2f}\n", c.x(), c.y(), reach * look.x(),
                     reach * look.y(), i + 1, -c.z());
  }
  e += "EOD\n";
  std::string lamp;
  if (r.options.hypothesis.lamp_frame == LampFrame::kBoard) {
    const Eigen::Vector3d& l = r.options.hypothesis.lamp;
    lamp = fmt::format(
        ", '-' using 1:2 with points pt 3 ps 3 lc rgb '#e0a000' title "
        "{}\n{:.4f} {:.4f}\ne",
        GnuplotQuote(fmt::format("lamp, {:.2f} m up", -l.z())), l.x(), l.y());
  }
  e += "plot $cams using 1:2:3:4 with vectors head filled lw 2 lc rgb '#2060c0' title "
       "'camera -> sample', $cams using 1:2:(sprintf('%d (%.2f m)', $5, $6)) with labels "
       "offset 0,1 notitle" +
       lamp + "\n";
  spec.extra = e;
  RenderPlot(spec, out);
}

// The viewing directions in the sample's frame relative to the lamp: theta_r as the radius,
// phi (0 = back towards the lamp) as the angle, colour theta_i; one point per view at the sample
// centre and at each corner of the sample region, so each view shows the spread it covers.
void PlotCoverage(const PlanResult& r, const Board& board, const fs::path& out) {
  PlotSpec spec;
  spec.title = "theta_r (radius, deg), phi (angle; 0: the lamp's side), theta_i (colour)";
  spec.xlabel = "theta_r cos(phi) (deg)";
  spec.ylabel = "theta_r sin(phi) (deg)";
  spec.width = 900;
  spec.height = 560;
  std::vector<Eigen::Vector3d> points = {board.SampleCentre()};
  for (const auto& q : board.sample_region()) points.emplace_back(q.x(), q.y(), 0.0);
  std::string e =
      "set size ratio -1\nset xrange [-90:90]\nset yrange [-5:90]\nset cbrange [0:90]\n"
      "set cblabel 'theta_i (deg)'\nset palette defined (0 'blue', 45 'green', 90 'red')\n"
      "set object circle at 0,0 size 90 fs empty border lc rgb '#a0a0a0'\n"
      "set object circle at 0,0 size 45 fs empty border lc rgb '#d0d0d0'\n";
  for (const auto* views : {&r.plan, &r.orbit}) {
    e += views == &r.plan ? "$plan << EOD\n" : "$orbit << EOD\n";
    for (const auto& v : *views) {
      for (const auto& p : points) {
        const Angles<double> a = AnglesAt(v, r.options.hypothesis, p);
        const double tr = RadToDeg(a.theta_r);
        e += fmt::format("{:.3f} {:.3f} {:.3f}\n", tr * std::cos(a.phi), tr * std::sin(a.phi),
                         RadToDeg(a.theta_i));
      }
    }
    e += "EOD\n";
  }
  e += "plot $plan using 1:2:3 with points pt 7 ps 1.5 lc palette title 'plan', $orbit using "
       "1:2:3 with points pt 6 ps 1.5 lc palette title 'default orbit'\n";
  spec.extra = e;
  RenderPlot(spec, out);
}

std::string PlanCsv(const PlanResult& r, const Board& board) {
  const Eigen::Vector3d centre = board.SampleCentre();
  std::string s =
      "view,polar_deg,azimuth_deg,distance_m,camera_x_m,camera_y_m,camera_height_m,"
      "theta_i_deg,theta_r_deg,phi_deg,patches,saturated_patches\n";
  for (size_t i = 0; i < r.plan.size(); ++i) {
    const PlannedView& v = r.plan[i];
    const Eigen::Vector3d c = v.cam_from_board.Inverse().t;
    const Angles<double> a = AnglesAt(v, r.options.hypothesis, centre);
    s += fmt::format("{},{:.1f},{:.1f},{:.3f},{:.4f},{:.4f},{:.4f},{:.1f},{:.1f},{:.1f},{},{}\n",
                     i + 1, v.polar_deg, v.azimuth_deg, v.distance_m, c.x(), c.y(), -c.z(),
                     RadToDeg(a.theta_i), RadToDeg(a.theta_r), RadToDeg(std::abs(a.phi)), v.patches,
                     v.saturated);
  }
  return s;
}

}  // namespace

std::string PlanResult::Report() const {
  std::string s = fmt::format(
      "plan: {} views chosen from {} reachable candidates ({}-optimal, greedy + exchange)\n",
      plan.size(), candidates, ToString(options.criterion));
  for (size_t i = 0; i < plan.size(); ++i) {
    s += fmt::format("  view {:>2}: polar {:>4.0f} deg, azimuth {:>5.0f} deg, distance {:.2f} m\n",
                     i + 1, plan[i].polar_deg, plan[i].azimuth_deg, plan[i].distance_m);
  }
  s += "predicted standard deviations (scatter: pixel noise only; reported: what the fit will "
       "say, with its 1% floor):\n";
  s += PredictionTable(plan_prediction, orbit_prediction);
  s += fmt::format("criterion: plan {}, default orbit {} (lower is better)\n",
                   Figure(plan_criterion, "unusable"), Figure(orbit_criterion, "unusable"));
  return s;
}

nlohmann::json PlanResult::ToJson() const {
  const DesignHypothesis& h = options.hypothesis;
  nlohmann::json j = {
      {"hypothesis",
       {{"model", h.model},
        {"params", h.params},
        {"lamp_frame", ToString(h.lamp_frame)},
        {"lamp", {h.lamp.x(), h.lamp.y(), h.lamp.z()}},
        {"intensity", h.intensity}}},
      {"white_albedo", options.white_albedo ? nlohmann::json(*options.white_albedo) : nullptr},
      {"criterion", ToString(options.criterion)},
      {"exposure_s", options.exposure_s},
      {"candidates", candidates},
      {"plan_criterion", FiniteOrNull(plan_criterion)},
      {"orbit_criterion", FiniteOrNull(orbit_criterion)},
      {"plan_prediction", plan_prediction.ToJson()},
      {"orbit_prediction", orbit_prediction.ToJson()}};
  for (const auto& v : plan) j["views"].push_back(ViewJson(v));
  for (const auto& v : orbit) j["orbit_views"].push_back(ViewJson(v));
  return j;
}

void WritePlan(const PlanResult& r, const Board& board, const CameraModel& camera,
               const fs::path& out) {
  (void)camera;
  const fs::path abs = fs::absolute(out).lexically_normal();
  if (fs::exists(abs) && !fs::is_directory(abs)) {
    throw InputError("--out: " + out.string() + " is a file");
  }
  EnsureDirectory(abs.parent_path());
  const fs::path tmp = abs.parent_path() / fmt::format(".gonio-plan-tmp-{}", getpid());
  fs::remove_all(tmp);
  const TemporaryGuard guard(tmp);
  try {
    EnsureDirectory(tmp);
    WriteJsonAtomically(tmp / "plan.json", r.ToJson());
    WriteTextAtomically(tmp / "plan.csv", PlanCsv(r, board));
    PlotTopView(r, board, tmp / "plan.png");
    PlotCoverage(r, board, tmp / "coverage.png");
    const fs::path old = abs.parent_path() / fmt::format(".gonio-plan-old-{}", getpid());
    if (fs::exists(abs)) fs::rename(abs, old);
    fs::rename(tmp, abs);
    fs::remove_all(old);
  } catch (...) {
    fs::remove_all(tmp);
    throw;
  }
}

std::vector<Rigid3d> ReadPlanPoses(const fs::path& path) {
  const nlohmann::json j = ReadJsonFile(path);
  std::vector<Rigid3d> poses;
  try {
    for (const auto& v : j.at("views")) poses.push_back(RigidFromJson(v.at("cam_from_board")));
  } catch (const nlohmann::json::exception& e) {
    throw InputError("--plan: " + path.string() + ": not a plan.json (" + e.what() + ")");
  }
  if (poses.empty()) throw InputError("--plan: " + path.string() + " holds no views");
  return poses;
}

PlanCoverage CompareWithPlan(const std::vector<Rigid3d>& planned,
                             const std::vector<Rigid3d>& achieved, const Eigen::Vector3d& target,
                             double max_angle_deg) {
  PlanCoverage c;
  c.max_angle_deg = max_angle_deg;
  for (const Rigid3d& p : planned) {
    const Eigen::Vector3d dp = p.Inverse().t - target;
    double best = INFINITY, ratio = INFINITY;
    for (const Rigid3d& a : achieved) {
      const Eigen::Vector3d da = a.Inverse().t - target;
      const double angle =
          RadToDeg(std::acos(std::clamp(dp.normalized().dot(da.normalized()), -1.0, 1.0)));
      if (angle < best) {
        best = angle;
        ratio = da.norm() / dp.norm();
      }
    }
    c.nearest_angle_deg.push_back(best);
    c.nearest_distance_ratio.push_back(ratio);
    if (best <= max_angle_deg && std::abs(ratio - 1) <= 0.15) ++c.covered;
  }
  return c;
}

std::string PlanCoverage::Report() const {
  std::string s = fmt::format(
      "plan coverage: {} of {} planned views photographed (within {:.0f} deg and 15% of the "
      "distance)\n",
      covered, nearest_angle_deg.size(), max_angle_deg);
  for (size_t i = 0; i < nearest_angle_deg.size(); ++i) {
    const bool ok =
        nearest_angle_deg[i] <= max_angle_deg && std::abs(nearest_distance_ratio[i] - 1) <= 0.15;
    if (!ok) {
      s += fmt::format("  view {}: nearest frame {} deg away, {} x the distance\n", i + 1,
                       Figure(nearest_angle_deg[i], "(none located)"),
                       Figure(nearest_distance_ratio[i], "-"));
    }
  }
  return s;
}

nlohmann::json PlanCoverage::ToJson() const {
  nlohmann::json views = nlohmann::json::array();
  for (size_t i = 0; i < nearest_angle_deg.size(); ++i) {
    views.push_back({{"nearest_angle_deg", FiniteOrNull(nearest_angle_deg[i])},
                     {"nearest_distance_ratio", FiniteOrNull(nearest_distance_ratio[i])}});
  }
  return {{"planned", nearest_angle_deg.size()},
          {"covered", covered},
          {"max_angle_deg", max_angle_deg},
          {"views", views}};
}

void AddPlanCoverage(const std::vector<Rigid3d>& planned, const Board& board, RunResult* result) {
  std::vector<Rigid3d> achieved;
  for (const auto& f : result->poses.frames) achieved.push_back(f.pose.cam_from_board);
  const PlanCoverage c = CompareWithPlan(planned, achieved, board.SampleCentre());
  result->plan_coverage = c.ToJson();
  result->plan_coverage_report = c.Report();
}

}  // namespace gonio
