#include "smseg/stacks/point_features.hpp"

#include "smseg/common/names.hpp"
#include "smseg/common/options.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <unordered_map>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

namespace smseg::stacks {

namespace {

Eigen::Matrix3d rotation(const sequence::Pose& p) {
  Eigen::Matrix3d R;
  R << p.R[0], p.R[1], p.R[2], p.R[3], p.R[4], p.R[5], p.R[6], p.R[7], p.R[8];
  return R;
}
Eigen::Vector3d centre(const sequence::Pose& p) { return {p.t[0], p.t[1], p.t[2]}; }

// Sets a and b to va and vb on every pixel whose centre lies inside the triangle t (x0,y0,x1,y1,x2,y2),
// edges included: one pass over the triangle's bounding box with edge functions.
void fill_triangle(cv::Mat& a, cv::Mat& b, const cv::Vec6f& t, double va, double vb) {
  const double x0 = t[0], y0 = t[1], x1 = t[2], y1 = t[3], x2 = t[4], y2 = t[5];
  double area = (x1 - x0) * (y2 - y0) - (x2 - x0) * (y1 - y0);
  if (area == 0) return;
  const double s = area > 0 ? 1.0 : -1.0;  // orient the edge functions so that inside is >= 0
  const int xmin = std::max(0, static_cast<int>(std::ceil(std::min({x0, x1, x2}))));
  const int xmax = std::min(a.cols - 1, static_cast<int>(std::floor(std::max({x0, x1, x2}))));
  const int ymin = std::max(0, static_cast<int>(std::ceil(std::min({y0, y1, y2}))));
  const int ymax = std::min(a.rows - 1, static_cast<int>(std::floor(std::max({y0, y1, y2}))));
  const double eps = -1e-9;
  for (int y = ymin; y <= ymax; ++y) {
    double* pa = a.ptr<double>(y);
    double* pb = b.ptr<double>(y);
    for (int x = xmin; x <= xmax; ++x) {
      const double e0 = s * ((x1 - x0) * (y - y0) - (y1 - y0) * (x - x0));
      const double e1 = s * ((x2 - x1) * (y - y1) - (y2 - y1) * (x - x1));
      const double e2 = s * ((x0 - x2) * (y - y2) - (y0 - y2) * (x - x2));
      if (e0 >= eps && e1 >= eps && e2 >= eps) {
        pa[x] = va;
        pb[x] = vb;
      }
    }
  }
}

}  // namespace

const std::vector<std::string>& structure_feature_names() {
  static const std::vector<std::string> names = {"fH", "fC", "fOx", "fOy", "fD", "fR"};
  return names;
}

constexpr std::array<EnumName<HeightReference>, 3> kHeightReferenceNames{
    {{HeightReference::Auto, "auto"}, {HeightReference::Plane, "plane"}, {HeightReference::Camera, "camera"}}};

std::string to_string(HeightReference h) { return name_of(kHeightReferenceNames, h); }
HeightReference height_reference_from_string(const std::string& s, const std::string& option) {
  return value_named(kHeightReferenceNames, s, option);
}

// The cameras' median height (world Y of their centres) over the frames: HeightReference::Camera's
// reference, the camera height the SfM scaled its run to.
static double median_camera_height(const std::vector<sequence::Pose>& poses) {
  if (poses.empty()) return 0;
  std::vector<double> ys;
  ys.reserve(poses.size());
  for (const sequence::Pose& p : poses) ys.push_back(centre(p).y());
  const auto mid = ys.begin() + static_cast<std::ptrdiff_t>(ys.size() / 2);
  std::nth_element(ys.begin(), mid, ys.end());
  return *mid;
}

std::optional<double> reference_camera_height(const FeatureOptions& opt, const std::vector<sequence::Pose>& poses) {
  if (opt.height_reference != HeightReference::Camera) return std::nullopt;
  // Causal features know only the frames so far: the first camera's height (the front ends put the
  // first camera camera_height above the ground), as a live stream takes it (FeatureStream).
  if (opt.causal) return poses.empty() ? 0.0 : centre(poses.front()).y();
  return median_camera_height(poses);
}

double height_shift(std::optional<double> camera_height, const sequence::Pose& pose) {
  return camera_height ? *camera_height - centre(pose).y() : 0.0;
}

const options::Table<FeatureOptions>& feature_options_table() {
  using F = FeatureOptions;
  static const options::Table<F> table = [] {
    options::Table<F> t("feature");
    // stacks.json records each field (feature_options_json); the ones added after the first work
    // folders only when set, so that those folders keep resuming.
    t.flag("causal", "--causal",
           "only what is known at each frame (on-line use, what label-stream computes): fC from the camera\n"
           "path up to the frame, and a track's points from the frame it reaches --min-track-frames on",
           [](auto& o) -> auto& { return o.causal; })
        .only(options::kCommandLine | options::kFile | options::kPython);  // configs: per side, their own key
    t.flag("appearance", "--appearance",
           "also the image's own channels, after the six: fL fA fB (Lab colour), fG0..fG3 (gradient\n"
           "magnitude by orientation) and fRow fCol (position); train-forest --features fH,fC,fOx,fOy,fD,fR\n"
           "leaves them out (structure and motion only)",
           [](auto& o) -> auto& { return o.appearance; })
        .recorded_unless([](const F& o) { return !o.appearance; });
    t.flag("dense", "--dense",
           "also dense geometry channels, after the others: fZV (valid), fZI (inverse depth), fZH (height),\n"
           "fZU (surface facing up), fZE (depth edges), fZC (distance to the camera path), from semi-global\n"
           "matching (stereo) or a plane sweep over the SfM's posed neighbour frames (mono); structure and\n"
           "motion, not appearance (docs/stereo.md, docs/sfm.md)",
           [](auto& o) -> auto& { return o.dense; })
        .recorded_unless([](const F& o) { return !o.dense; });
    t.number("sweep_baseline", "--sweep-baseline",
             "--dense, monocular: metres between the frame's camera and each neighbour the plane sweep reads\n"
             "(the nearest frame each side at least this far, within --sweep-reach frames); a video much\n"
             "denser than its training runs can match their baseline (docs/camvid.md)",
             [](auto& o) -> auto& { return o.sweep_baseline; }, 0.05, 1000.0)
        .recorded_unless_default();
    t.number("sweep_reach", "--sweep-reach", "--dense, monocular: frames either side the plane sweep looks for its neighbours in",
             [](auto& o) -> auto& { return o.sweep_reach; }, 1, 1000)
        .recorded_unless_default();
    t.number("sweep_scale", "--sweep-scale",
             "--dense, monocular: the plane sweep's resolution against the frame's (0.5: half the width and\n"
             "height, a quarter to an eighth of the time; the depth is brought back to the frame's size)",
             [](auto& o) -> auto& { return o.sweep_scale; }, 0.1, 1.0)
        .recorded_unless_default();
    t.choice("height_reference", "--height-reference",
             "what fH and fZH measure heights from: plane (the run's ground plane, world Y), camera (the\n"
             "ground under each frame's camera: its height relative to the camera plus the cameras' median\n"
             "height, so a drifting monocular camera path does not shift them) or auto (camera for\n"
             "structure from motion, plane for stereo)",
             [](auto& o) -> auto& { return o.height_reference; }, kHeightReferenceNames)
        .recorded_unless([](const F& o) { return o.height_reference != HeightReference::Camera; });
    t.number("future_frames", "--future-frames",
             "frames of camera motion applied to a point's last position (fC), and of the camera path\n"
             "ahead that fZC measures to (--dense)",
             [](auto& o) -> auto& { return o.future_frames; }, 0, 100000);
    return t;
  }();
  return table;
}

void FeatureOptions::validate() const {
  if (future_frames < 0 || future_frames > 100000)
    throw Error("", "--future-frames", "must be in 0..100000 (got " + std::to_string(future_frames) + ")");
  // The sweep never takes a neighbour nearer than SweepNeighbourOptions::min_baseline (0.05 m).
  if (!(sweep_baseline >= 0.05 && sweep_baseline <= 1000))
    throw Error("", "--sweep-baseline", "must be in 0.05..1000 metres (got " + std::to_string(sweep_baseline) + ")");
  if (sweep_reach < 1 || sweep_reach > 1000)
    throw Error("", "--sweep-reach", "must be in 1..1000 frames (got " + std::to_string(sweep_reach) + ")");
  if (!(sweep_scale >= 0.1 && sweep_scale <= 1))
    throw Error("", "--sweep-scale", "must be in 0.1..1 (got " + std::to_string(sweep_scale) + ")");
}

void CausalPointAttributes::add_frame(const sequence::Pose& pose, const std::vector<Observation>& obs, FrameAttributes& out) {
  const Eigen::Matrix3d R = rotation(pose);
  const Eigen::Vector3d C = centre(pose);
  const double shift = height_shift(camera_height_, pose);
  out.world.resize(obs.size());
  out.fH.resize(obs.size());
  out.fC.resize(obs.size());
  out.fR.resize(obs.size());
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const Eigen::Vector3d w = R * obs[i].cam + C;
    out.world[i] = w;
    out.fH[i] = w.y() + shift;
    TrackState& t = tracks_[obs[i].track];
    out.fR[i] = t.last_frame >= 0 ? (w - t.last_world).norm() : 0.0;
    t.running_min = std::min(t.running_min, (w - C).norm());
    out.fC[i] = t.running_min;  // causal value: camera path up to this frame
    t.last_frame = frame_;
    t.last_world = w;
  }
  ++frame_;
}

void CausalPointAttributes::keep_only(const std::vector<int>& live_tracks) {
  for (auto it = tracks_.begin(); it != tracks_.end();)
    it = std::binary_search(live_tracks.begin(), live_tracks.end(), it->first) ? std::next(it) : tracks_.erase(it);
}

const CausalPointAttributes::TrackState* CausalPointAttributes::track(int id) const {
  const auto it = tracks_.find(id);
  return it == tracks_.end() ? nullptr : &it->second;
}

PointAttributes compute_point_attributes(const PointCloudVideo& video, const FeatureOptions& opt) {
  opt.validate();
  const int n = video.frame_count();
  if (static_cast<int>(video.observations.size()) != n)
    throw Error("", "observations", "one list of observations per pose is needed");
  PointAttributes a;
  a.world.resize(n);
  a.fH.resize(n);
  a.fC.resize(n);
  a.fR.resize(n);
  CausalPointAttributes causal(reference_camera_height(opt, video.poses));
  std::unordered_map<int, std::vector<std::pair<int, int>>> seen;  // per track: (frame, index in that frame)
  for (int f = 0; f < n; ++f) {
    FrameAttributes fa;
    causal.add_frame(video.poses[f], video.observations[f], fa);
    a.world[f] = std::move(fa.world);
    a.fH[f] = std::move(fa.fH);
    a.fC[f] = std::move(fa.fC);
    a.fR[f] = std::move(fa.fR);
    if (!opt.causal)
      for (std::size_t i = 0; i < video.observations[f].size(); ++i)
        seen[video.observations[f][i].track].emplace_back(f, static_cast<int>(i));
  }
  if (!opt.causal) {
    // Whole track plus the next future_frames frames of camera motion applied to its last position.
    for (const auto& [id, at] : seen) {
      const CausalPointAttributes::TrackState& t = *causal.track(id);
      double best = t.running_min;
      const int end = std::min(n - 1, t.last_frame + opt.future_frames);
      for (int f = t.last_frame + 1; f <= end; ++f) best = std::min(best, (t.last_world - centre(video.poses[f])).norm());
      for (const auto& [f, i] : at) a.fC[f][i] = best;
    }
  }
  return a;
}

std::vector<cv::Mat> rasterise_features(const PointCloudVideo& video, const PointAttributes& attrs, int frame,
                                        cv::Size size) {
  std::vector<cv::Mat> r;
  rasterise_features(video, attrs, frame, size, r);
  return r;
}

void rasterise_features(const PointCloudVideo& video, const PointAttributes& attrs, int frame, cv::Size size,
                        std::vector<cv::Mat>& r) {
  r.resize(6);
  for (auto& m : r) {
    m.create(size, CV_64FC1);  // reuses the buffer when the size matches: no page faults per frame
    m.setTo(0.0);
  }
  const auto& obs = video.observations.at(frame);
  const Eigen::Vector3d cam_centre = centre(video.poses.at(frame));

  // Point features at the point's pixel.
  std::vector<cv::Point2f> pts;
  std::vector<int> index_of_pt;
  pts.reserve(obs.size());
  for (std::size_t i = 0; i < obs.size(); ++i) {
    const int x = static_cast<int>(std::lround(obs[i].x)), y = static_cast<int>(std::lround(obs[i].y));
    if (x < 0 || y < 0 || x >= size.width || y >= size.height) continue;
    r[0].at<double>(y, x) += attrs.fH[frame][i];
    r[1].at<double>(y, x) += attrs.fC[frame][i];
    r[4].at<double>(y, x) += 1.0;
    r[5].at<double>(y, x) += attrs.fR[frame][i];
    pts.emplace_back(obs[i].x, obs[i].y);
    index_of_pt.push_back(static_cast<int>(i));
  }

  // Orientation: Delaunay triangulation of the image positions, world normals filled per triangle.
  if (pts.size() >= 3) {
    cv::Subdiv2D subdiv(cv::Rect(-1, -1, size.width + 2, size.height + 2));
    // getTriangleList returns the inserted coordinates exactly, so they identify the observation.
    std::unordered_map<std::uint64_t, int> obs_at;  // a duplicate position keeps its first point
    const auto key = [](float x, float y) {
      std::uint32_t bx, by;
      std::memcpy(&bx, &x, 4);
      std::memcpy(&by, &y, 4);
      return (std::uint64_t(bx) << 32) | by;
    };
    for (std::size_t k = 0; k < pts.size(); ++k) {
      subdiv.insert(pts[k]);
      obs_at.emplace(key(pts[k].x, pts[k].y), index_of_pt[k]);
    }
    std::vector<cv::Vec6f> tris;
    subdiv.getTriangleList(tris);
    for (const auto& t : tris) {
      int ids[3];
      bool ok = true;
      for (int k = 0; k < 3 && ok; ++k) {
        auto it = obs_at.find(key(t[2 * k], t[2 * k + 1]));
        ok = it != obs_at.end();  // false for the outer virtual vertices
        if (ok) ids[k] = it->second;
      }
      if (!ok) continue;
      const Eigen::Vector3d& v1 = attrs.world[frame][ids[0]];
      const Eigen::Vector3d& v2 = attrs.world[frame][ids[1]];
      const Eigen::Vector3d& v3 = attrs.world[frame][ids[2]];
      Eigen::Vector3d nrm = (v3 - v1).cross(v2 - v1);
      const double len = nrm.norm();
      if (!(len > 1e-12)) continue;  // degenerate (collinear) triangle
      nrm /= len;
      if (nrm.dot(cam_centre - (v1 + v2 + v3) / 3.0) < 0) nrm = -nrm;  // face the camera
      fill_triangle(r[2], r[3], t, nrm.x(), nrm.y());
    }
  }
}

cv::Mat summed_area_table(const cv::Mat& raster) {
  cv::Mat sat;
  summed_area_table(raster, sat);
  return sat;
}

void summed_area_table(const cv::Mat& raster, cv::Mat& sat) {
  CV_Assert(raster.type() == CV_64FC1);
  cv::integral(raster, sat, CV_64F);
}

double rect_sum(const cv::Mat& sat, int x0, int y0, int x1, int y1) {
  const int w = sat.cols - 1, h = sat.rows - 1;
  x0 = std::clamp(x0, 0, w);
  x1 = std::clamp(x1, 0, w);
  y0 = std::clamp(y0, 0, h);
  y1 = std::clamp(y1, 0, h);
  if (x1 <= x0 || y1 <= y0) return 0.0;
  return sat.at<double>(y1, x1) - sat.at<double>(y0, x1) - sat.at<double>(y1, x0) + sat.at<double>(y0, x0);
}

}  // namespace smseg::stacks
