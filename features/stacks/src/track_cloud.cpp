#include "smseg/stacks/track_cloud.hpp"

#include <algorithm>
#include <cmath>
#include <unordered_map>

#include <opencv2/imgproc.hpp>

namespace smseg::stacks {

std::vector<CloudPoint> track_cloud(const frontend::FrontEndResult& fe, const PointCloudVideo& video,
                                    const PointAttributes& attrs) {
  std::vector<Eigen::Vector3d> sum(fe.tracks.size(), Eigen::Vector3d::Zero());
  std::vector<int> count(fe.tracks.size(), 0);
  for (int f = 0; f < video.frame_count(); ++f)
    for (std::size_t i = 0; i < video.observations[f].size(); ++i) {
      const int t = video.observations[f][i].track;
      if (t < 0 || t >= static_cast<int>(fe.tracks.size())) continue;
      sum[t] += attrs.world[f][i];
      ++count[t];
    }
  std::vector<CloudPoint> cloud;
  cloud.reserve(fe.tracks.size());
  for (std::size_t t = 0; t < fe.tracks.size(); ++t) {
    if (count[t] == 0) continue;
    CloudPoint p;
    p.position = (sum[t] / count[t]).cast<float>();
    p.label = fe.tracks[t].label;
    p.track = static_cast<int>(t);
    cloud.push_back(p);
  }
  return cloud;
}

cv::Mat plot_top_down(const std::vector<sequence::Pose>& path, const std::vector<sequence::Pose>* gt, const std::vector<CloudPoint>& cloud,
                      const sequence::Sequence& seq, int size) {
  // Extent: the paths and the central 98% of the cloud (a few far outliers must not shrink the plot).
  std::vector<double> xs, zs;
  for (const auto& p : path) {
    xs.push_back(p.t[0]);
    zs.push_back(p.t[2]);
  }
  if (gt)
    for (const auto& p : *gt) {
      xs.push_back(p.t[0]);
      zs.push_back(p.t[2]);
    }
  std::vector<double> cx, cz;
  for (const auto& c : cloud) {
    cx.push_back(c.position.x());
    cz.push_back(c.position.z());
  }
  const auto central = [](std::vector<double> v, std::vector<double>& out) {
    if (v.empty()) return;
    std::sort(v.begin(), v.end());
    out.push_back(v[v.size() / 100]);
    out.push_back(v[v.size() - 1 - v.size() / 100]);
  };
  central(cx, xs);
  central(cz, zs);
  if (xs.empty()) {
    xs = {-1, 1};
    zs = {-1, 1};
  }
  const double x0 = *std::min_element(xs.begin(), xs.end()) - 0.5, x1 = *std::max_element(xs.begin(), xs.end()) + 0.5;
  const double z0 = *std::min_element(zs.begin(), zs.end()) - 0.5, z1 = *std::max_element(zs.begin(), zs.end()) + 0.5;
  const double scale = (size - 40) / std::max(x1 - x0, z1 - z0);
  const auto px = [&](double x, double z) {
    return cv::Point(20 + static_cast<int>((x - x0) * scale), size - 20 - static_cast<int>((z - z0) * scale));
  };
  cv::Mat img(size, size, CV_8UC3, cv::Scalar::all(255));
  for (const auto& c : cloud) {
    cv::Scalar colour(170, 170, 170);
    if (c.label >= 0 && c.label < static_cast<int>(seq.classes.size())) {
      const auto& rgb = seq.classes[c.label].rgb;
      colour = cv::Scalar(rgb[2], rgb[1], rgb[0]);
    }
    cv::circle(img, px(c.position.x(), c.position.z()), 1, colour, cv::FILLED);
  }
  const auto draw_path = [&](const std::vector<sequence::Pose>& p, const cv::Scalar& colour) {
    for (std::size_t i = 1; i < p.size(); ++i)
      cv::line(img, px(p[i - 1].t[0], p[i - 1].t[2]), px(p[i].t[0], p[i].t[2]), colour, 2, cv::LINE_AA);
    if (!p.empty()) cv::circle(img, px(p[0].t[0], p[0].t[2]), 5, colour, 2, cv::LINE_AA);
  };
  if (gt) draw_path(*gt, cv::Scalar(40, 40, 220));
  draw_path(path, cv::Scalar(0, 0, 0));
  const cv::Point bar(20, 14);
  cv::line(img, bar, bar + cv::Point(static_cast<int>(scale), 0), cv::Scalar::all(0), 2);
  cv::putText(img, "1 m", bar + cv::Point(static_cast<int>(scale) + 6, 5), cv::FONT_HERSHEY_SIMPLEX, 0.45,
              cv::Scalar::all(0), 1, cv::LINE_AA);
  cv::putText(img, gt ? "black: estimated path, red: ground truth; points: tracked, class colours" :
                        "black: estimated path; points: tracked, class colours",
              cv::Point(20, size - 6), cv::FONT_HERSHEY_SIMPLEX, 0.4, cv::Scalar::all(60), 1, cv::LINE_AA);
  return img;
}

}  // namespace smseg::stacks
