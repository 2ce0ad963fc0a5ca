// sfs scenes: the image equals the material's radiance under the collocated lamp through the
// chain, and the depth/normal truth describes the rendered shape.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "common/camera_model.h"
#include "common/io.h"
#include "data_synth/scene.h"
#include "tests/data_synth/synth_test_util.h"

namespace gonio::testing {
namespace {

using json = nlohmann::json;

// A preset made small and Lambertian (registered on every build).
json SmallSfsScene(const std::string& preset, double offaxis_deg = 0) {
  synth::PresetOptions options;
  options.sfs_lamp_offaxis_deg = offaxis_deg;
  json j = synth::SceneToJson(synth::PresetScene(preset, options));
  j["material"] = {{"model", "lambert"}, {"params", {{"albedo", 0.8}}}};
  j["camera"]["intrinsics"] = {250, 250, 99.5, 74.5};
  j["camera"]["width"] = 200;
  j["camera"]["height"] = 150;
  return j;
}

TEST(SfsRenderTest, SphereImageDepthAndNormalsMatchTheGeometry) {
  TempDir dir;
  const auto scene = WriteScene(dir.path(), SmallSfsScene("sfs-sphere"));
  const auto out = dir.path() / "sphere";
  const auto r = RunGonio("synth --scene " + scene + " --out " + out.string());
  ASSERT_EQ(r.exit_code, 0) << r.err;
  for (const char* f : {"image.png", "mask.png", "camera.cameramodel", "material.json", "lamp.json",
                        "truth.json", "depth.tiff", "normals.tiff"}) {
    EXPECT_TRUE(std::filesystem::exists(out / f)) << f;
  }
  const json truth = ReadJsonFile(out / "truth.json");
  const json lamp = ReadJsonFile(out / "lamp.json");
  const json material = ReadJsonFile(out / "material.json");
  EXPECT_EQ(material.at("selected"), "lambert");
  EXPECT_DOUBLE_EQ(material.at("candidates")[0].at("params").at("albedo").get<double>(), 0.8);
  EXPECT_TRUE(lamp.at("collocated").get<bool>());
  const double radius = truth.at("object").at("radius");
  Eigen::Vector3d centre_in_cam;
  for (int i = 0; i < 3; ++i) centre_in_cam[i] = truth.at("object").at("centre_in_camera")[i];

  const CameraModel cam = CameraModel::Read(out / "camera.cameramodel");
  const cv::Mat image = cv::imread((out / "image.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat mask = cv::imread((out / "mask.png").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat depth = cv::imread((out / "depth.tiff").string(), cv::IMREAD_UNCHANGED);
  const cv::Mat normals = cv::imread((out / "normals.tiff").string(), cv::IMREAD_UNCHANGED);
  ASSERT_EQ(depth.type(), CV_32F);
  ASSERT_EQ(normals.type(), CV_32FC3);
  const double per_dn = lamp.at("radiance_per_dn");
  int inside = 0;
  double worst_depth = 0, worst_normal = 0, worst_value = 0;
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      if (!mask.at<uint8_t>(y, x)) continue;
      ++inside;
      // The pixel ray's exact intersection with the sphere.
      const Eigen::Vector3d d = cam.Unproject(Eigen::Vector2d(x, y)).normalized();
      const double b = d.dot(centre_in_cam),
                   disc = b * b - centre_in_cam.squaredNorm() + radius * radius;
      ASSERT_GT(disc, 0) << "mask pixel whose ray misses the sphere";
      const Eigen::Vector3d p = (b - std::sqrt(disc)) * d;
      const Eigen::Vector3d n = (p - centre_in_cam) / radius;
      worst_depth = std::max(worst_depth, std::abs(depth.at<float>(y, x) - p.z()));
      // Stored as RGB = (x, y, z); OpenCV hands it back as BGR.
      const cv::Vec3f nf = normals.at<cv::Vec3f>(y, x);
      worst_normal = std::max(worst_normal, (Eigen::Vector3d(nf[2], nf[1], nf[0]) - n).norm());
      // Lambert under the collocated lamp: L = albedo/pi * I cos(theta_i) / d^2.
      const double cos_i = n.dot(-p.normalized());
      const double radiance = 0.8 / M_PI * cos_i / p.squaredNorm();
      worst_value = std::max(worst_value, std::abs(image.at<uint16_t>(y, x) - radiance / per_dn));
    }
  }
  // Projected disc area: pi (f R / sqrt(D^2 - R^2))^2, less the silhouette ring of width ~1 px.
  const double r_px = 250 * radius / std::sqrt(centre_in_cam.squaredNorm() - radius * radius);
  EXPECT_NEAR(inside, M_PI * (r_px - 1) * (r_px - 1), 2 * M_PI * r_px);
  EXPECT_LT(worst_depth, 1e-6);
  EXPECT_LT(worst_normal, 1e-5);
  EXPECT_LE(worst_value, 0.51);
  std::printf("sphere: %d mask pixels, worst depth %.2g m, normal %.2g, value %.3f DN\n", inside,
              worst_depth, worst_normal, worst_value);
}

TEST(SfsRenderTest, VaseAndBumpsRenderWithMaskInsideTheImageAndUnitNormals) {
  for (const std::string shape : {"vase", "bumps"}) {
    TempDir dir;
    const auto scene = WriteScene(dir.path(), SmallSfsScene("sfs-" + shape, 20.0));
    const auto out = dir.path() / shape;
    const auto r = RunGonio("synth --scene " + scene + " --out " + out.string());
    ASSERT_EQ(r.exit_code, 0) << r.err;
    const cv::Mat mask = cv::imread((out / "mask.png").string(), cv::IMREAD_UNCHANGED);
    const cv::Mat normals = cv::imread((out / "normals.tiff").string(), cv::IMREAD_UNCHANGED);
    const cv::Mat image = cv::imread((out / "image.png").string(), cv::IMREAD_UNCHANGED);
    const json lamp = ReadJsonFile(out / "lamp.json");
    EXPECT_FALSE(lamp.at("collocated").get<bool>());
    // 20 deg off axis, same distance from the object centre.
    const Eigen::Vector3d lamp_in_cam(lamp.at("position")[0], lamp.at("position")[1],
                                      lamp.at("position")[2]);
    const Eigen::Vector3d centre_in_cam(0, 0, 0.5);
    EXPECT_NEAR(
        std::acos((-centre_in_cam).normalized().dot((lamp_in_cam - centre_in_cam).normalized())) *
            180 / M_PI,
        20, 1e-9);
    int inside = 0, border = 0, lit = 0;
    for (int y = 0; y < mask.rows; ++y) {
      for (int x = 0; x < mask.cols; ++x) {
        if (!mask.at<uint8_t>(y, x)) continue;
        ++inside;
        border += x == 0 || y == 0 || x == mask.cols - 1 || y == mask.rows - 1;
        const cv::Vec3f n = normals.at<cv::Vec3f>(y, x);
        EXPECT_NEAR(cv::norm(n), 1.0, 1e-5);
        EXPECT_LT(n[0], 0) << "normal faces the camera (z is channel 0 in OpenCV's BGR)";
        lit += image.at<uint16_t>(y, x) > 0;
      }
    }
    // The normal truth agrees with the depth truth: normals from central differences of the
    // back-projected depth map, where all four neighbours are on the object.
    const cv::Mat depth = cv::imread((out / "depth.tiff").string(), cv::IMREAD_UNCHANGED);
    const CameraModel cam = CameraModel::Read(out / "camera.cameramodel");
    auto point = [&](int x, int y) {
      return Eigen::Vector3d(cam.Unproject(Eigen::Vector2d(x, y)) * depth.at<float>(y, x));
    };
    std::vector<double> angle_deg;
    for (int y = 1; y + 1 < mask.rows; ++y) {
      for (int x = 1; x + 1 < mask.cols; ++x) {
        if (!mask.at<uint8_t>(y, x) || !mask.at<uint8_t>(y, x - 1) || !mask.at<uint8_t>(y, x + 1) ||
            !mask.at<uint8_t>(y - 1, x) || !mask.at<uint8_t>(y + 1, x)) {
          continue;
        }
        Eigen::Vector3d n_fd =
            (point(x + 1, y) - point(x - 1, y)).cross(point(x, y + 1) - point(x, y - 1));
        n_fd.normalize();
        if (n_fd.z() > 0) n_fd = -n_fd;
        const cv::Vec3f nf = normals.at<cv::Vec3f>(y, x);  // BGR: (z, y, x)
        const double c = std::clamp(n_fd.dot(Eigen::Vector3d(nf[2], nf[1], nf[0])), -1.0, 1.0);
        angle_deg.push_back(std::acos(c) * 180 / M_PI);
      }
    }
    ASSERT_GT(angle_deg.size(), 1000u);
    std::sort(angle_deg.begin(), angle_deg.end());
    const double median = angle_deg[angle_deg.size() / 2];
    const double p95 = angle_deg[angle_deg.size() * 95 / 100];
    std::printf("%s: normals vs depth differences: median %.3f deg, p95 %.3f deg\n", shape.c_str(),
                median, p95);
    EXPECT_LT(median, 0.5) << shape;
    EXPECT_LT(p95, 2.0) << shape;
    EXPECT_GT(inside, 0.15 * mask.total()) << shape;
    EXPECT_EQ(border, 0) << shape;
    EXPECT_GT(lit, 0.95 * inside) << shape;
  }
}

}  // namespace
}  // namespace gonio::testing
