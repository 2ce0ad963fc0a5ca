#include "pipeline/report.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <map>
#include <sstream>

#include <fmt/format.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "common/io.h"
#include "common/math.h"
#include "common/plot.h"
#include "pipeline/observed_angles.h"
#include "reflectance/registry.h"

namespace gonio {
namespace {

std::string Escape(const std::string& s) {
  std::string out;
  for (char c : s) {
    if (c == '<')
      out += "&lt;";
    else if (c == '>')
      out += "&gt;";
    else if (c == '&')
      out += "&amp;";
    else
      out += c;
  }
  return out;
}

// Measured f_r = L / (I cos(theta_i) / d^2) against signed theta_r (negative: source side),
// per theta_i bin, with the fitted model's value at the same geometry: the papers' figures.
void BrdfPlot(const JointFitResult& f, const ObservationSet& data,
              const std::filesystem::path& png) {
  std::map<int, std::pair<PlotSeries, PlotSeries>> bins;
  const ModelInfo& info = FindModel(f.material.model);
  (void)info;
  const size_t stride = std::max<size_t>(1, data.observations.size() / 4000);
  for (size_t i = 0; i < data.observations.size(); i += stride) {
    const auto& o = data.observations[i];
    if (o.white) continue;
    Angles<double> a;
    double e = 0;
    if (!ObservationGeometry(o, f, &a, &e) || !(e > 0)) continue;
    const int bin = static_cast<int>(std::lround(RadToDeg(a.theta_i) / 5.0)) * 5;
    const double x = RadToDeg(a.theta_r) * (std::cos(a.phi) >= 0 ? -1.0 : 1.0);
    BrdfSample s{a.theta_i, a.theta_r, a.phi, 0, 1};
    auto& [meas, fitted] = bins[bin];
    meas.x.push_back(x);
    // The lamp's part of the radiance: a fitted ambient constant subtracted (docs/pipeline.md).
    const double ambient = f.ambient_sample.empty() ? 0.0 : f.ambient_sample[0];
    meas.y.push_back((o.radiance[0] - ambient) / (f.intensity * e));
    fitted.x.push_back(x);
    fitted.y.push_back(f.material.Predict(s));
  }
  PlotSpec spec;
  spec.title = fmt::format("{}: measured (dots) and fitted (crosses) BRDF", f.material.model);
  spec.xlabel = "theta_r (deg), negative = source side";
  spec.ylabel = "f_r (1/sr, relative without a white reference)";
  int color = 1;
  for (auto& [bin, pair] : bins) {
    pair.first.label = fmt::format("theta_i ~ {} deg", bin);
    pair.first.style = fmt::format("points pt 7 ps 0.4 lc {}", color);
    pair.second.label = "";
    pair.second.style = fmt::format("points pt 2 ps 0.6 lc {}", color);
    spec.series.push_back(pair.first);
    spec.series.push_back(pair.second);
    ++color;
  }
  spec.extra = "set xrange [-90:90]";
  RenderPlot(spec, png);
}

void PolarPlot(const JointFitResult& f, double theta_i, const std::filesystem::path& png) {
  PlotSpec spec;
  spec.title = fmt::format("{} in the plane of incidence, theta_i = {:.0f} deg (polar)",
                           f.material.model, RadToDeg(theta_i));
  spec.width = spec.height = 700;
  PlotSeries s;
  s.label = "f_r";
  for (int k = -89; k <= 89; ++k) {
    const double tr = DegToRad(std::abs(k));
    BrdfSample q{theta_i, tr, k < 0 ? 0.0 : kPi, 0, 1};
    const double v = f.material.Predict(q);
    // Angle measured from the normal (up): gnuplot polar takes the angle from +x.
    s.x.push_back(90.0 + k);
    s.y.push_back(v);
  }
  spec.series.push_back(s);
  spec.extra =
      "set polar\nset angles degrees\nset size square\nunset xtics\nunset ytics\nset grid polar 15";
  RenderPlot(spec, png);
}

// Residual image per frame: (model - measured) / measured at every observation's pixel,
// blue (model too dark) - white - red (model too bright), +-10% full scale, one tile per frame
// in a montage. Spatial patterns (a gradient across the sample, one bright corner) show what a
// single number per frame hides: a wrong lamp, a vignetting error, a textured sample.
void ResidualMontage(const JointFitResult& f, const ObservationSet& data,
                     const std::filesystem::path& png) {
  double max_x = 0, max_y = 0;
  int frames = 0;
  for (const auto& o : data.observations) {
    max_x = std::max(max_x, o.px);
    max_y = std::max(max_y, o.py);
    frames = std::max(frames, o.frame + 1);
  }
  const int scale = 4, cols = std::min(6, std::max(1, frames));
  const int tw = static_cast<int>(max_x) / scale + 2, th = static_cast<int>(max_y) / scale + 2;
  const int rows = (frames + cols - 1) / cols;
  cv::Mat montage(rows * th, cols * tw, CV_8UC3, cv::Scalar(40, 40, 40));
  for (const auto& o : data.observations) {
    if (o.white) continue;
    Angles<double> a;
    double e = 0;
    if (!ObservationGeometry(o, f, &a, &e) || !(o.radiance[0] > 0)) continue;
    const double pred =
        f.material.Predict(BrdfSample{a.theta_i, a.theta_r, a.phi, 0, 1}) * f.intensity * e;
    const double rel = std::clamp((pred - o.radiance[0]) / o.radiance[0] / 0.1, -1.0, 1.0);
    const int x = (o.frame % cols) * tw + static_cast<int>(o.px) / scale;
    const int y = (o.frame / cols) * th + static_cast<int>(o.py) / scale;
    const uint8_t fade = static_cast<uint8_t>(255 * (1 - std::abs(rel)));
    const cv::Vec3b colour = rel > 0 ? cv::Vec3b(fade, fade, 255) : cv::Vec3b(255, fade, fade);
    cv::rectangle(montage, cv::Rect(x, y, 1, 1), cv::Scalar(colour[0], colour[1], colour[2]),
                  cv::FILLED);
  }
  for (int k = 0; k < frames; ++k) {
    cv::putText(montage, std::to_string(k), cv::Point((k % cols) * tw + 4, (k / cols) * th + 14),
                cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(255, 255, 255), 1);
  }
  WriteAtomically(
      png, [&](const std::filesystem::path& tmp) { return cv::imwrite(tmp.string(), montage); });
}

void FramePlot(const JointFitResult& f, const std::filesystem::path& png) {
  PlotSpec spec;
  spec.title = "mean relative residual per frame (a moved lamp or sample shows as an outlier)";
  spec.xlabel = "frame";
  spec.ylabel = "(model - measured) / measured";
  PlotSeries s;
  s.label = "frames";
  s.style = "impulses lw 4";
  for (const auto& fr : f.frames) {
    s.x.push_back(fr.frame);
    s.y.push_back(fr.mean_relative);
  }
  spec.series.push_back(s);
  RenderPlot(spec, png);
}

void GeometrySketch(const JointFitResult& f, const ObservationSet& data, const Board& board,
                    const std::filesystem::path& png) {
  PlotSpec spec;
  spec.title = "capture geometry (board frame, metres): board, cameras, fitted lamp";
  spec.width = spec.height = 800;
  std::map<int, Eigen::Vector3d> cams;
  for (const auto& o : data.observations) cams[o.frame] = o.camera_in_board;
  PlotSeries cam, lamp, sample;
  cam.label = "camera centres";
  cam.style = "points pt 7 ps 1";
  for (const auto& [k, c] : cams) {
    cam.x.push_back(c.x());
    cam.y.push_back(c.z());
  }
  // gnuplot 2-D views would hide depth: use splot through "extra" with inline data instead.
  std::ostringstream gp;
  gp << "set view 60,30\nset xlabel 'x'\nset ylabel 'y'\nset zlabel 'z'\nset ticslevel 0\n";
  gp << "$cams << EOD\n";
  for (const auto& [k, c] : cams) gp << c.x() << ' ' << c.y() << ' ' << c.z() << '\n';
  gp << "EOD\n$lamp << EOD\n";
  Eigen::Vector3d l = f.lamp_position;
  if (f.lamp_frame == LampFrame::kCamera && !data.observations.empty()) {
    Angles<double> a;
    double e;
    // Show the lamp for the first frame: board_from_cam applied to the camera-frame position.
    (void)a;
    (void)e;
    l = data.observations[0].camera_in_board;
  }
  gp << l.x() << ' ' << l.y() << ' ' << l.z() << "\nEOD\n$board << EOD\n";
  for (const auto* poly : {&board.sample_region(), &board.white_region()}) {
    for (const auto& q : *poly) gp << q.x() << ' ' << q.y() << " 0\n";
    if (!poly->empty()) gp << poly->front().x() << ' ' << poly->front().y() << " 0\n";
    gp << "\n";
  }
  gp << "EOD\n";
  gp << "splot $board with lines lw 2 title 'sample and white regions', $cams with points pt 7 "
        "title 'cameras', $lamp with points pt 3 ps 3 lc rgb 'red' title 'fitted lamp'\n";
  spec.extra = gp.str();
  spec.series.clear();
  RenderPlot(spec, png);
}

// Parameter-table rows for the room's light and a fitted sample height (docs/pipeline.md).
std::string AmbientRows(const JointFitResult& f) {
  auto sd = [](const std::vector<std::optional<double>>& v, size_t k) {
    return k < v.size() && v[k] ? fmt::format("{:.2g}", *v[k]) : std::string("undetermined");
  };
  std::string rows;
  if (f.ambient != AmbientTerm::kFit) {
    rows = fmt::format("<tr><td>ambient</td><td colspan=2>{}</td></tr>",
                       f.lamp_off_frames > 0
                           ? fmt::format("lamp-off frames subtracted ({})", f.lamp_off_frames)
                           : std::string("not modelled"));
  }
  for (size_t c = 0; c < f.ambient_sample.size(); ++c) {
    rows += fmt::format("<tr><td>ambient radiance, sample [{}]</td><td>{:.4g}</td><td>{}</td></tr>",
                        c, f.ambient_sample[c], sd(f.ambient_sample_stddev, c));
  }
  for (size_t c = 0; c < f.ambient_irradiance.size(); ++c) {
    rows += fmt::format("<tr><td>ambient irradiance [{}]</td><td>{:.4g}</td><td>{}</td></tr>", c,
                        f.ambient_irradiance[c], sd(f.ambient_irradiance_stddev, c));
  }
  if (f.sample_height_offset) {
    rows += fmt::format("<tr><td>sample height correction</td><td>{:+.2f} mm</td><td>{}</td></tr>",
                        1e3 * *f.sample_height_offset,
                        f.sample_height_offset_stddev
                            ? fmt::format("{:.2g} mm", 1e3 * *f.sample_height_offset_stddev)
                            : std::string("undetermined"));
  }
  return rows;
}

// The warnings at the top of the page, numbered, each with the results it touches.
std::string WarningBox(const std::vector<RunWarning>& warnings) {
  if (warnings.empty()) return "<p><b>Warnings:</b> none.</p>";
  std::string h =
      "<div style='border:2px solid #b00;padding:6px;margin:6px 0'><b style='color:#b00'>" +
      fmt::format("{} warning{}", warnings.size(), warnings.size() > 1 ? "s" : "") +
      "</b> (the results they touch are marked below)<ol>";
  for (const auto& w : warnings) {
    std::string touched;
    for (const auto& t : w.touches) touched += (touched.empty() ? "" : ", ") + t;
    h += "<li style='color:#b00'>[" + Escape(ToString(w.cause)) + "] " + Escape(w.message) +
         (touched.empty() ? std::string(" <i>(touches no result)</i>")
                          : " <i>(touches: " + Escape(touched) + ")</i>") +
         "</li>";
  }
  return h + "</ol></div>";
}

// The numbers of the warnings that touch `result`, as a table cell ("" when none).
std::string WarnedCell(const std::vector<RunWarning>& warnings, const std::string& result) {
  std::string list;
  for (size_t k = 0; k < warnings.size(); ++k) {
    const auto& t = warnings[k].touches;
    if (std::find(t.begin(), t.end(), result) != t.end()) {
      list += (list.empty() ? "" : ", ") + std::to_string(k + 1);
    }
  }
  return list.empty() ? "<td></td>" : "<td style='color:#b00'>warning " + list + "</td>";
}

// The report's figures: BRDF against theta_r, the polar plot at the mean incidence of a
// sample of the observations, the per-frame values, residuals and the geometry sketch.
void WriteReportPlots(const JointFitResult& f, const ObservationSet& data, const Board& board,
                      const std::filesystem::path& dir) {
  BrdfPlot(f, data, dir / "brdf_vs_theta_r.png");
  double mean_ti = 0;
  size_t n = 0;
  for (size_t i = 0; i < data.observations.size(); i += 50) {
    Angles<double> a;
    double e;
    if (!data.observations[i].white && ObservationGeometry(data.observations[i], f, &a, &e)) {
      mean_ti += a.theta_i;
      ++n;
    }
  }
  PolarPlot(f, n ? mean_ti / n : 0.5, dir / "polar.png");
  FramePlot(f, dir / "frames.png");
  ResidualMontage(f, data, dir / "residuals.png");
  GeometrySketch(f, data, board, dir / "geometry.png");
}

// A standard deviation's statistical and calibration parts as two cells: the calibration part
// is the refits' spread, added in quadrature to the fit's own (AddCalibrationUncertainty), so
// the statistical part is what remains. Per component for the lamp.
std::string SplitCells(const std::optional<Eigen::VectorXd>& total, const Eigen::VectorXd& part) {
  if (!total) return "<td>-</td><td>-</td>";
  const Eigen::VectorXd stat =
      (total->array().square() - part.array().square()).max(0.0).sqrt().matrix();
  auto cell = [](const Eigen::VectorXd& v) {
    if (v.size() == 1) return fmt::format("<td>{:.2g}</td>", v[0]);
    return fmt::format("<td>({:.2g}, {:.2g}, {:.2g})</td>", v[0], v[1], v[2]);
  };
  return cell(stat) + cell(part);
}

std::optional<Eigen::VectorXd> Scalar(const std::optional<double>& v) {
  if (!v) return std::nullopt;
  return Eigen::VectorXd::Constant(1, *v);
}

// The parameters with their standard deviations (split into their statistical and calibration
// parts when the calibration's error was propagated) and warnings, the lamp, the intensity and
// the ambient terms, as an HTML table.
std::string ParameterTable(const JointFitResult& f, const std::vector<RunWarning>& warnings,
                           const ReportErrorBars& bars) {
  const auto& cal = bars.calibration;
  std::ostringstream h;
  h << "<h2>Parameters</h2><table><tr><th>parameter</th><th>value</th><th>std. dev.</th>"
    << (cal ? "<th>statistical</th><th>calibration, poses</th>" : "") << "<th>touched by</th></tr>";
  for (size_t k = 0; k < f.material.params.size(); ++k) {
    const auto& sd = f.material.stddev[k];
    std::string split;
    if (cal) {  // the refits' spread in the fit's parameter order (calibration_error.h)
      const double part = k < cal->param_stddev.size() ? cal->param_stddev[k] : 0.0;
      split = SplitCells(Scalar(sd), Eigen::VectorXd::Constant(1, part));
    }
    h << fmt::format("<tr><td>{}</td><td>{:.5g}</td><td>{}</td>{}{}</tr>",
                     f.material.param_names[k], f.material.params[k],
                     sd ? fmt::format("{:.2g}", *sd) : "undetermined", split,
                     WarnedCell(warnings, f.material.param_names[k]));
  }
  std::optional<Eigen::VectorXd> lamp_sd;
  if (f.lamp_stddev) lamp_sd = Eigen::VectorXd(*f.lamp_stddev);
  h << fmt::format(
      "<tr><td>lamp ({} frame)</td><td>({:.4f}, {:.4f}, {:.4f}) m</td><td>{}</td>{}{}</tr>",
      ToString(f.lamp_frame), f.lamp_position.x(), f.lamp_position.y(), f.lamp_position.z(),
      f.lamp_stddev ? fmt::format("({:.2g}, {:.2g}, {:.2g})", f.lamp_stddev->x(),
                                  f.lamp_stddev->y(), f.lamp_stddev->z())
                    : "undetermined",
      cal ? SplitCells(lamp_sd, Eigen::VectorXd(cal->lamp_stddev)) : "",
      WarnedCell(warnings, "lamp"));
  h << fmt::format("<tr><td>intensity</td><td>{:.5g}</td><td>{}</td>{}{}</tr>", f.intensity,
                   f.intensity_stddev ? fmt::format("{:.2g}", *f.intensity_stddev) : "undetermined",
                   cal ? SplitCells(Scalar(f.intensity_stddev),
                                    Eigen::VectorXd::Constant(1, cal->intensity_stddev))
                       : "",
                   WarnedCell(warnings, "intensity"));
  h << AmbientRows(f) << "</table>";
  return h.str();
}

// What the standard deviations above hold and what they leave out (docs/pipeline.md, Chain,
// step 5): a bar is a claim, and the reader should not have to open fit.json to weigh it.
std::string ErrorBarNote(const JointFitResult& f, const ReportErrorBars& bars) {
  std::string h = "<p><b>What the standard deviations hold:</b></p><ul>";
  h += fmt::format(
      "<li>statistical: the pixel noise and a relative noise floor of {:.2f}% ({}), scaled by "
      "the residuals' variance per degree of freedom when above 1",
      100 * bars.noise_floor, Escape(bars.noise_floor_source));
  if (bars.statistical_rescale != 1) {
    h += fmt::format(
        "; multiplied by {:.2f}, since the floor is the calibration's accuracy, propagated below",
        bars.statistical_rescale);
  }
  h += ";</li>";
  if (bars.calibration) {
    const auto& c = *bars.calibration;
    h += fmt::format(
        "<li>calibration: the refits' spread over {} draws of {}, added in quadrature;</li>",
        c.draws,
        c.photometric && c.poses ? "the photometric calibration's stated error and the board "
                                   "poses' covariance"
        : c.poses                ? "the board poses' covariance (the photometric calibration "
                                   "states no accuracy)"
                                 : "the photometric calibration's stated error");
  } else {
    h += "<li>calibration: not propagated (the photometric calibration states no accuracy and "
         "the poses carry no covariance);</li>";
  }
  h += f.patch_model == PatchModel::kAverage
           ? std::string("<li>patches: the model is averaged over each patch's footprint;</li>")
       : f.patch_bias_bound_sd
           ? fmt::format(
                 "<li>patches: the model is taken at each patch's centre (its bias "
                 "bounded by {:.2g} standard deviations);</li>",
                 *f.patch_bias_bound_sd)
           : std::string(
                 "<li>patches: the model is taken at each patch's centre, its bias not "
                 "bounded (--patch-model centre);</li>");
  h += "<li>not held: the camera model's own error (its intrinsics), a bias common to the "
       "located poses (the tag corners'), and whatever a warning above names.</li></ul>";
  return h;
}

// Every candidate model's fit and criteria, the selected one in bold, as an HTML table.
std::string ModelComparisonTable(const JointSelectionResult& fit) {
  std::ostringstream h;
  h << "<h2>Model comparison</h2><table><tr><th>model</th><th>k</th><th>rel_rms</th><th>AIC</th>"
       "<th>BIC</th><th>CV rms (held-out frames)</th><th>undetermined</th></tr>";
  for (size_t k = 0; k < fit.selection.candidates.size(); ++k) {
    const auto& c = fit.selection.candidates[k];
    std::string und;
    for (const auto& u : c.undetermined) und += (und.empty() ? "" : ", ") + u;
    h << fmt::format(
        "<tr{}><td>{}</td><td>{}</td><td>{:.4f}</td><td>{:.1f}</td><td>{:.1f}</td>"
        "<td>{}</td><td>{}</td></tr>",
        static_cast<int>(k) == fit.selection.selected ? " style='font-weight:bold'" : "", c.model,
        c.n_params, c.rel_rms, c.aic, c.bic,
        c.cv_rms ? fmt::format("{:.4g}", *c.cv_rms) : std::string("-"), und);
  }
  h << "</table>";
  return h.str();
}

// `gonio run --error-budget` (estimation/joint/error_budget.h): each quantity's standard
// deviation by part, each cell with a bar of its share of the variance, so the part to shrink
// stands out without reading the numbers.
std::string BudgetTable(const CalibrationErrorBudget& b) {
  std::ostringstream h;
  h << "<h2>Error budget</h2><p>Each calibration error source refitted alone; the parts add in "
       "quadrature to the total (within the refits' own spread). Bars: share of the "
       "variance.</p><table><tr><th>quantity</th><th>total</th><th>statistical</th>";
  for (auto s : b.sources) h << "<th>" << ToString(s) << "</th>";
  h << "<th>largest</th></tr>";
  const auto cell = [](double sd, double total) {
    const double share = total > 0 ? std::min(1.0, sd * sd / (total * total)) : 0.0;
    return fmt::format(
        "<td>{:.2g}<div style='background:#48c;height:4px;width:{:.0f}%'></div></td>", sd,
        100 * share);
  };
  for (const auto& row : b.rows) {
    h << "<tr><td>" << Escape(row.quantity) << "</td><td>" << fmt::format("{:.2g}", row.total)
      << "</td>" << cell(row.statistical, row.total);
    for (const auto& v : row.by_source) h << (v ? cell(*v, row.total) : "<td>-</td>");
    h << "<td>" << PartName(row.Largest(b.sources)) << "</td></tr>";
  }
  h << "</table>";
  for (const auto& n : b.notes) h << "<p>Not measured: " << Escape(n) << "</p>";
  return h.str();
}

}  // namespace

void WriteReport(const JointSelectionResult& fit, const ObservationSet& data, const Board& board,
                 const std::vector<std::string>& notes, const std::vector<RunWarning>& warnings,
                 const ReportErrorBars& bars, const std::filesystem::path& dir) {
  EnsureDirectory(dir);
  const JointFitResult& f = fit.final_fit;
  WriteReportPlots(f, data, board, dir);

  std::ostringstream h;
  h << "<!doctype html><html><head><meta charset='utf-8'><title>gonio report</title>"
       "<style>body{font-family:sans-serif;max-width:1100px;margin:auto}table{border-collapse:"
       "collapse}td,th{border:1px solid #ccc;padding:3px "
       "8px;text-align:right}</style></head><body>";
  h << "<h1>gonio: " << Escape(f.material.model) << "</h1>";
  for (const auto& a : notes) {
    h << "<p style='color:#b00;border:2px solid #b00;padding:6px'>" << Escape(a) << "</p>";
  }
  h << WarningBox(warnings);
  h << "<p><b>Selection:</b> " << Escape(fit.selection.reason) << "</p>";
  // What the geometry could measure: a lamp beside the lens sees the backscatter diagonal only.
  const ObservedAngles angles = ObservedAnglesOf(f, data);
  h << "<p" << (angles.backscatter_only ? " style='color:#b00'" : "") << "><b>Observed:</b>";
  std::istringstream angle_lines(angles.Report());
  for (std::string line; std::getline(angle_lines, line);) h << " " << Escape(line) << "<br>";
  h << "</p>";
  h << ParameterTable(f, warnings, bars) << ErrorBarNote(f, bars);
  if (bars.budget) h << BudgetTable(*bars.budget);
  if (!f.absolute) {
    std::string note = f.RelativeNote();
    note[0] = static_cast<char>(std::toupper(static_cast<unsigned char>(note[0])));
    h << "<p>" << Escape(note) << ".</p>";
  }
  h << ModelComparisonTable(fit);
  h << "<p>Residual image per frame (tile = frame, blue: model darker, red: model brighter than "
       "measured, full scale +-10%):</p>";
  for (const char* img :
       {"residuals.png", "brdf_vs_theta_r.png", "polar.png", "frames.png", "geometry.png"}) {
    h << "<p><img src='" << img << "' style='max-width:100%'></p>";
  }
  h << "</body></html>\n";
  WriteTextAtomically(dir / "index.html", h.str());
}

}  // namespace gonio
