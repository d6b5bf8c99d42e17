// Rendering and writing of the synthetic stereo video (see synth.hpp): per-frame tile binning of the
// quads, one ray per pixel, shading, sensor model, files and manifest, montage.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <numbers>

#include <opencv2/imgproc.hpp>
#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include "smseg/common/progress.hpp"
#include "synth_detail.hpp"

namespace smseg::synth {

using detail::Rgb;
using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

constexpr int kTile = 8;
constexpr double kPi = std::numbers::pi;

Matrix3d rotation(const sequence::Pose& p) {
  Matrix3d R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R(i, j) = p.R[3 * i + j];
  return R;
}

/// Per tile of kTile x kTile pixels, the indices (ascending) of the quads whose projection may cover it.
struct Bins {
  int tiles_x = 0, tiles_y = 0;
  std::vector<std::vector<int>> lists;
  std::vector<double> num;  ///< per quad: (centre - C).dot(normal)
  const std::vector<int>& at(int x, int y) const { return lists[(y / kTile) * tiles_x + x / kTile]; }
};

Bins bin_quads(const std::vector<Quad>& quads, const sequence::Pose& pose, const SynthOptions& o) {
  Bins b;
  b.tiles_x = (o.width + kTile - 1) / kTile;
  b.tiles_y = (o.height + kTile - 1) / kTile;
  b.lists.resize(static_cast<std::size_t>(b.tiles_x) * b.tiles_y);
  const Matrix3d Rt = rotation(pose).transpose();
  const Vector3d C(pose.t[0], pose.t[1], pose.t[2]);
  const double fx = o.fx(), cx = o.cx(), cy = o.cy();
  const double z_near = 0.5 * detail::kMinLambda;
  b.num.resize(quads.size());
  for (std::size_t i = 0; i < quads.size(); ++i) {
    const Quad& q = quads[i];
    b.num[i] = (q.centre - C).dot(q.normal);
    if (!(b.num[i] < 0)) continue;  // seen from behind: no ray can hit it
    Vector3d poly[8];
    Vector3d in[4];
    const Vector3d du = q.u * q.hu, dv = q.v * q.hv;
    in[0] = Rt * (q.centre - du - dv - C);
    in[1] = Rt * (q.centre + du - dv - C);
    in[2] = Rt * (q.centre + du + dv - C);
    in[3] = Rt * (q.centre - du + dv - C);
    // Clip the quad against the near plane z = z_near (Sutherland-Hodgman).
    int n = 0;
    for (int k = 0; k < 4; ++k) {
      const Vector3d& a = in[k];
      const Vector3d& c = in[(k + 1) % 4];
      const bool ina = a.z() >= z_near, inc = c.z() >= z_near;
      if (ina) poly[n++] = a;
      if (ina != inc) poly[n++] = a + (c - a) * ((z_near - a.z()) / (c.z() - a.z()));
    }
    if (n == 0) continue;
    double x0 = 1e300, y0 = 1e300, x1 = -1e300, y1 = -1e300;
    for (int k = 0; k < n; ++k) {
      const double z = std::max(poly[k].z(), z_near);
      const double u = fx * poly[k].x() / z + cx, v = fx * poly[k].y() / z + cy;
      x0 = std::min(x0, u);
      x1 = std::max(x1, u);
      y0 = std::min(y0, v);
      y1 = std::max(y1, v);
    }
    // One pixel of margin for rounding; pixel centres are at integer coordinates.
    x0 = std::max(x0 - 1.0, 0.0);
    y0 = std::max(y0 - 1.0, 0.0);
    x1 = std::min(x1 + 1.0, o.width - 1.0);
    y1 = std::min(y1 + 1.0, o.height - 1.0);
    if (x0 > x1 || y0 > y1) continue;
    const int tx0 = static_cast<int>(x0) / kTile, tx1 = static_cast<int>(x1) / kTile;
    const int ty0 = static_cast<int>(y0) / kTile, ty1 = static_cast<int>(y1) / kTile;
    for (int ty = ty0; ty <= ty1; ++ty)
      for (int tx = tx0; tx <= tx1; ++tx) b.lists[ty * b.tiles_x + tx].push_back(static_cast<int>(i));
  }
  return b;
}

/// Gamma 2.2 lookup from linear 0..1 to 0..255.
const std::vector<float>& gamma_lut() {
  static const std::vector<float> lut = [] {
    std::vector<float> l(4097);
    for (int i = 0; i <= 4096; ++i) l[i] = static_cast<float>(255.0 * std::pow(i / 4096.0, 1.0 / 2.2));
    return l;
  }();
  return lut;
}

/// Approximately standard normal from 40 random bits (Irwin-Hall sum of four 10-bit uniforms).
inline float gauss(std::uint64_t h) {
  const float s = static_cast<float>(h & 0x3ff) + static_cast<float>((h >> 10) & 0x3ff) +
                  static_cast<float>((h >> 20) & 0x3ff) + static_cast<float>((h >> 30) & 0x3ff);
  return ((s + 2.0f) * (1.0f / 1024.0f) - 2.0f) * 1.7320508f;
}

/// What the pixels of one camera's view share: the scene, the camera, the binned quads, the lights
/// near the camera and the exposure (global drift, camera gain, vignetting, gamma).
struct View {
  /// A light as the shading loop reads it.
  struct LightF {
    float x, y, z, r, g, b;
  };
  const Scene& sc;
  const SynthOptions& o;
  const std::vector<Quad>& quads;
  const sequence::Pose& pose;
  Bins bins;
  Vector3d C;
  double fxd, cxd, cyd;
  float fx, gain, r2max, range2;
  Rgb cam_gain;
  const std::vector<float>& lut;
  std::vector<LightF> lights;

  View(const Scene& scene, const SynthOptions& opts, const std::vector<Quad>& qs, const sequence::Pose& p, int frame, int camera)
      : sc(scene), o(opts), quads(qs), pose(p), bins(bin_quads(qs, p, opts)), C(p.t[0], p.t[1], p.t[2]),
        fxd(opts.fx()), cxd(opts.cx()), cyd(opts.cy()), fx(static_cast<float>(fxd)),
        gain(static_cast<float>(1.0 + 0.12 * std::sin(2 * kPi * frame_time(opts, frame) / 20.0 + scene.gain_phase))),
        r2max(static_cast<float>(opts.cx() * opts.cx() + opts.cy() * opts.cy())),
        range2(static_cast<float>(scene.light_range * scene.light_range)),
        cam_gain(camera == 0 ? Rgb{1.0f, 1.0f, 1.0f} : Rgb{0.965f, 0.95f, 0.985f}), lut(gamma_lut()) {
    // Lights that can reach anything near the camera's view (within range of the visible region).
    for (const auto& l : sc.lights)
      if ((l.position - C).norm() < sc.light_range + 12.0)
        lights.push_back({static_cast<float>(l.position.x()), static_cast<float>(l.position.y()),
                          static_cast<float>(l.position.z()), l.intensity[0], l.intensity[1], l.intensity[2]});
  }

  /// Radiance -> exposure (global drift, camera gain, vignetting) -> gamma, as BGR.
  cv::Vec3f shade(int x, int y, Rgb col) const {
    const float dx = static_cast<float>(x - o.cx()), dy = static_cast<float>(y - o.cy());
    const float vig = 1.0f - 0.22f * (dx * dx + dy * dy) / r2max;
    col = col * cam_gain * (gain * vig);
    auto g = [&](float v) { return lut[static_cast<int>(std::clamp(v, 0.0f, 1.0f) * 4096.0f + 0.5f)]; };
    return cv::Vec3f(g(col.b), g(col.g), g(col.r));
  }

  /// Ambient light plus the near lights at point p of quad q.
  Rgb light_at(const Quad& q, const Vector3d& p) const {
    const float ny = static_cast<float>(q.normal.y());
    const float lr = static_cast<float>(sc.ambient) * (0.75f + 0.25f * ny);
    Rgb light{lr, lr, lr};
    const float px = static_cast<float>(p.x()), py = static_cast<float>(p.y()), pz = static_cast<float>(p.z());
    const float nx = static_cast<float>(q.normal.x()), nz = static_cast<float>(q.normal.z());
    for (const LightF& l : lights) {
      const float lx = l.x - px, ly = l.y - py, lz = l.z - pz;
      const float d2 = lx * lx + ly * ly + lz * lz;
      const float dot = lx * nx + ly * ny + lz * nz;
      if (d2 >= range2 || dot <= 0) continue;
      const float w = 1.0f - d2 / range2;
      const float att = dot / std::sqrt(d2) * w * w / (1.0f + 0.25f * d2);
      light.r += l.r * att;
      light.g += l.g * att;
      light.b += l.b * att;
    }
    return light;
  }

  /// The albedo of quad q where the ray d hits it at depth lambda, band-limited by the pixel's footprint.
  Rgb albedo_at(const Quad& q, const Vector3d& d, double lambda, const Vector3d& p) const {
    const Vector3d r = p - q.centre;
    const float s = static_cast<float>(r.dot(q.u) + q.hu + q.tex.x());
    const float tt = static_cast<float>(r.dot(q.v) + q.hv + q.tex.y());
    const double dn = d.norm();
    const float cosang = static_cast<float>(std::abs(d.dot(q.normal)) / dn);
    const float fp = static_cast<float>(lambda * dn) / (fx * std::sqrt(std::max(cosang, 0.02f)));
    return detail::albedo(sc.materials[q.material], s, tt, fp);
  }
};

/// The optional per-pixel outputs of a view: labels, depth, instance ids.
struct ViewMaps {
  cv::Mat *labels, *depth, *instances;
  void create(const SynthOptions& o) const {
    if (labels) labels->create(o.height, o.width, CV_8UC1);
    if (depth) depth->create(o.height, o.width, CV_32FC1);
    if (instances) instances->create(o.height, o.width, CV_8UC1);
  }
  void set(int y, int x, std::uint8_t cls, float z, std::uint8_t instance) const {
    if (labels) labels->at<std::uint8_t>(y, x) = cls;
    if (depth) depth->at<float>(y, x) = z;
    if (instances) instances->at<std::uint8_t>(y, x) = instance;
  }
};

/// One image row of linear BGR (after exposure and gamma, before blur and noise), and its maps.
void render_row(const View& v, int y, cv::Vec3f* row, const ViewMaps& maps) {
  int prev_hit = -1;
  Rgb prev_light;
  for (int x = 0; x < v.o.width; ++x) {
    const Vector3d d = detail::ray_direction(v.pose, v.fxd, v.cxd, v.cyd, x, y);
    double best = std::numeric_limits<double>::infinity();
    int hit = -1;
    for (int qi : v.bins.at(x, y))
      if (detail::intersect(v.quads[qi], v.bins.num[qi], v.C, d, best)) hit = qi;
    if (hit < 0) {
      row[x] = cv::Vec3f(0, 0, 0);
      maps.set(y, x, sequence::kVoid, 0.0f, 0);
      prev_hit = -1;
      continue;
    }
    const Quad& q = v.quads[hit];
    maps.set(y, x, q.cls, static_cast<float>(best), q.instance);
    const Vector3d p = v.C + best * d;
    const Rgb alb = v.albedo_at(q, d, best, p);
    const float emission = v.sc.materials[q.material].emission;
    // Light varies slowly over a surface: an odd pixel on the same quad as its left neighbour reuses
    // its light (halves the cost of the light loop; the difference is far below the noise).
    if (!((x & 1) && hit == prev_hit)) {
      prev_light = v.light_at(q, p);
      prev_hit = hit;
    }
    row[x] = v.shade(x, y, alb * prev_light + alb * emission);
  }
}

/// Sensor: read noise plus shot noise, from a counter-based hash of the seed, frame, camera and pixel.
void add_sensor_noise(const cv::Mat& lin, cv::Mat& image, const SynthOptions& o, int frame, int camera) {
  image.create(o.height, o.width, CV_8UC3);
  const float read2 = static_cast<float>(o.noise_sigma * o.noise_sigma);
  const bool noisy = o.noise_sigma > 0;
  const std::uint64_t base = detail::hash(o.seed, 6 /* noise stream */, static_cast<std::uint64_t>(frame),
                                          static_cast<std::uint64_t>(camera));
  for (int y = 0; y < o.height; ++y) {
    const cv::Vec3f* in = lin.ptr<cv::Vec3f>(y);
    cv::Vec3b* out = image.ptr<cv::Vec3b>(y);
    for (int x = 0; x < o.width; ++x) {
      // 120 random bits per pixel: 40 per channel.
      const std::uint64_t h1 = detail::hash(base, static_cast<std::uint64_t>(y) * o.width + x);
      const std::uint64_t h2 = detail::mix64(h1);
      const std::uint64_t bits[3] = {h1, (h1 >> 40) | (h2 << 24), h2 >> 16};
      for (int c = 0; c < 3; ++c) {
        float v = in[x][c];
        if (noisy) v += std::sqrt(read2 + 0.02f * std::max(v, 0.0f)) * gauss(bits[c]);
        out[x][c] = cv::saturate_cast<std::uint8_t>(v);
      }
    }
  }
}

/// Renders one camera: BGR image, and optionally labels and depth.
void render_view(const Scene& sc, const SynthOptions& o, const std::vector<Quad>& quads, const sequence::Pose& pose, int frame,
                 int camera, cv::Mat& image, cv::Mat* labels, cv::Mat* depth, cv::Mat* instances) {
  const View view(sc, o, quads, pose, frame, camera);
  const ViewMaps maps{labels, depth, instances};
  maps.create(o);
  cv::Mat lin(o.height, o.width, CV_32FC3);
  for (int y = 0; y < o.height; ++y) render_row(view, y, lin.ptr<cv::Vec3f>(y), maps);
  // Optics: a slight blur; then the sensor.
  cv::GaussianBlur(lin, lin, cv::Size(5, 5), 0.6, 0.6, cv::BORDER_REFLECT_101);
  add_sensor_noise(lin, image, o, frame, camera);
}

std::string frame_name(int f, const char* ext) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%06d%s", f, ext);
  return buf;
}

}  // namespace

Frame render_frame(const Scene& scene, const SynthOptions& opts, int frame) {
  Frame fr;
  fr.pose = camera_pose(scene, opts, frame);
  const std::vector<Quad> quads = quads_at(scene, frame_time(opts, frame));
  render_view(scene, opts, quads, fr.pose, frame, 0, fr.left, &fr.labels, &fr.depth, &fr.instances);
  sequence::Pose right = fr.pose;
  for (int i = 0; i < 3; ++i) right.t[i] += opts.baseline * fr.pose.R[3 * i + 0];
  render_view(scene, opts, quads, right, frame, 1, fr.right, nullptr, nullptr, nullptr);
  return fr;
}

namespace {

/// The output folders of a sequence (instances/ only for scenes with object instances).
void create_folders(const fs::path& out_dir, bool instances) {
  for (const char* sub : {"left", "right", "labels", "depth", "instances"}) {
    if (!instances && std::string(sub) == "instances") continue;
    std::error_code ec;
    fs::create_directories(out_dir / sub, ec);
    if (ec) throw Error((out_dir / sub).string(), "", "cannot create the folder: " + ec.message());
  }
}

/// The manifest of the sequence to render: name, calibration, classes and the files of every frame.
sequence::Sequence sequence_manifest(const SynthOptions& opts, const fs::path& out_dir, bool instances) {
  sequence::Sequence seq;
  seq.root = out_dir;
  seq.manifest = out_dir / sequence::kManifestName;
  seq.name = "synth-" + opts.scene + "-seed" + std::to_string(opts.seed);
  seq.kind = sequence::SequenceKind::Stereo;
  seq.size = cv::Size(opts.width, opts.height);
  seq.calibration.fx = opts.fx();
  seq.calibration.fy = opts.fx();
  seq.calibration.cx = opts.cx();
  seq.calibration.cy = opts.cy();
  seq.calibration.baseline = opts.baseline;
  seq.camera_height = opts.camera_y();
  seq.label_encoding = sequence::LabelEncoding::Rgb;
  seq.classes = classes(opts.scene);
  seq.void_class = void_class();
  for (int f = 0; f < opts.frames; ++f) {
    sequence::FrameEntry e;
    e.left = fs::path("left") / frame_name(f, ".png");
    e.right = fs::path("right") / frame_name(f, ".png");
    e.label = fs::path("labels") / frame_name(f, ".png");
    e.gt_depth = fs::path("depth") / frame_name(f, ".npy");
    e.time = frame_time(opts, f);
    if (f % opts.label_every == 0) {
      seq.labelled_frames.push_back(f);
      if (instances) e.instances = fs::path("instances") / frame_name(f, ".png");
    }
    seq.frames.push_back(e);
  }
  seq.gt_poses.resize(opts.frames);
  return seq;
}

/// Renders every frame in parallel and writes its files; the ground-truth poses into seq.
void render_frames(const Scene& scene, const SynthOptions& opts, const fs::path& out_dir, sequence::Sequence& seq) {
  Progress progress("make-sequence " + opts.scene, opts.frames, opts.progress);
  tbb::parallel_for(tbb::blocked_range<int>(0, opts.frames, 1), [&](const tbb::blocked_range<int>& range) {
    for (int f = range.begin(); f != range.end(); ++f) {
      const Frame fr = render_frame(scene, opts, f);
      const sequence::FrameEntry& e = seq.frames[f];
      sequence::write_image_atomic(out_dir / e.left, fr.left);
      sequence::write_image_atomic(out_dir / e.right, fr.right);
      sequence::write_image_atomic(out_dir / e.label, sequence::colour_labels(fr.labels, seq));
      sequence::write_npy_f32_atomic(out_dir / e.gt_depth, fr.depth);
      if (!e.instances.empty()) sequence::write_image_atomic(out_dir / e.instances, fr.instances);
      seq.gt_poses[f] = fr.pose;
      progress.tick();
    }
  });
  progress.finish();
}

/// The manifest's "extra": the generator, its options, what the files hold, and the scene's objects.
Json generator_extra(const SynthOptions& opts, const Scene& scene, bool instances) {
  Json options = {{"scene", opts.scene},
                  {"seed", opts.seed},
                  {"frames", opts.frames},
                  {"width", opts.width},
                  {"height", opts.height},
                  {"label_every", opts.label_every},
                  {"fps", opts.fps},
                  {"baseline", opts.baseline},
                  {"camera_height", opts.camera_y()},
                  {"hfov_deg", opts.hfov_deg},
                  {"speed", opts.speed},
                  {"noise_sigma", opts.noise_sigma}};
  Json extra = {{"generator", "make-sequence"},
                {"generator_version", 1},
                {"scene", opts.scene},
                {"seed", opts.seed},
                {"options", options},
                {"fps", opts.fps},
                {"depth", "z-depth along the left camera's optical axis, metres, float32; 0 = nothing hit"},
                {"labels", "every frame has a label image; labelled_frames marks every label_every-th"},
                {"people", scene.people.size()},
                {"static_quads", scene.quads.size()}};
  if (instances) {
    Json objects = Json::array();
    for (const Object& ob : scene.objects)
      objects.push_back({{"id", ob.id},
                         {"shape", ob.shape},
                         {"colour", ob.colour},
                         {"texture", ob.texture},
                         {"base", {ob.base.x(), ob.base.y(), ob.base.z()}},
                         {"size", {ob.size.x(), ob.size.y(), ob.size.z()}},
                         {"yaw", ob.yaw}});
    extra["objects"] = std::move(objects);
    extra["instances"] =
        "labelled frames have an instance image: 8-bit PNG, pixel = object id (objects[].id), 0 = not an object";
    extra["look_at"] = {scene.look_at.x(), scene.look_at.y(), scene.look_at.z()};
  }
  return extra;
}

}  // namespace

sequence::Sequence make_sequence(const SynthOptions& opts, const fs::path& out_dir) {
  opts.validate();
  const Scene scene = build_scene(opts);
  const bool instances = has_instances(opts.scene);
  create_folders(out_dir, instances);
  sequence::Sequence seq = sequence_manifest(opts, out_dir, instances);
  render_frames(scene, opts, out_dir, seq);
  seq.extra = generator_extra(opts, scene, instances);
  sequence::save_sequence(seq);
  return sequence::load_sequence(out_dir);
}

cv::Mat make_montage(const sequence::Sequence& seq, const std::vector<int>& frames, double max_depth, double scale) {
  if (frames.empty()) throw Error(seq.manifest.string(), "montage", "no frames to show");
  if (!(scale > 0.05 && scale <= 4)) throw Error("", "montage scale", "must be in (0.05, 4]");
  if (!(max_depth > 0)) throw Error("", "montage max_depth", "must be positive");
  const int W = static_cast<int>(std::lround(seq.size.width * scale));
  const int H = static_cast<int>(std::lround(seq.size.height * scale));
  const int gap = 4, header = 22;
  cv::Mat out(header + static_cast<int>(frames.size()) * (H + gap), 3 * W + 2 * gap, CV_8UC3, cv::Scalar(255, 255, 255));
  const char* titles[3] = {"left image", "labels", "depth (0-10 m)"};
  for (int c = 0; c < 3; ++c)
    cv::putText(out, titles[c], cv::Point(c * (W + gap) + 4, 16), cv::FONT_HERSHEY_SIMPLEX, 0.5, cv::Scalar(0, 0, 0), 1,
                cv::LINE_AA);
  auto place = [&](const cv::Mat& panel, int column, int y, int interpolation) {
    cv::Mat sized;
    if (panel.size() == cv::Size(W, H)) {
      sized = panel;
    } else {
      cv::resize(panel, sized, cv::Size(W, H), 0, 0, interpolation);
    }
    sized.copyTo(out(cv::Rect(column * (W + gap), y, W, H)));
  };
  for (std::size_t i = 0; i < frames.size(); ++i) {
    const int f = frames[i];
    const int y = header + static_cast<int>(i) * (H + gap);
    place(seq.load_left(f), 0, y, cv::INTER_AREA);
    cv::putText(out, "frame " + std::to_string(f), cv::Point(4, y + H - 6), cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
    place(sequence::colour_labels(seq.load_labels(f), seq), 1, y, cv::INTER_NEAREST);
    const cv::Mat d = seq.load_gt_depth(f);
    cv::Mat d8(d.size(), CV_8UC1);
    for (int r = 0; r < d.rows; ++r)
      for (int c = 0; c < d.cols; ++c) {
        const float z = d.at<float>(r, c);
        d8.at<std::uint8_t>(r, c) =
            z > 0 ? cv::saturate_cast<std::uint8_t>(255.0 * (1.0 - std::min(1.0, z / max_depth))) : 0;
      }
    cv::Mat dc;
    cv::applyColorMap(d8, dc, cv::COLORMAP_TURBO);
    dc.setTo(cv::Scalar(0, 0, 0), d <= 0);
    place(dc, 2, y, cv::INTER_AREA);
  }
  return out;
}

}  // namespace smseg::synth
