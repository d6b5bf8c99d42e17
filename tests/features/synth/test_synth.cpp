// Tests of the synthetic stereo video (make-sequence): ground truth against analytic geometry and the
// brute-force ray caster, stereo consistency of the images, labels, determinism, option validation.
#include <algorithm>
#include <cmath>
#include <fstream>
#include <random>
#include <set>
#include <sstream>

#include <Eigen/Dense>
#include <gtest/gtest.h>
#include <opencv2/imgproc.hpp>
#include <tbb/task_arena.h>
#include <unistd.h>

#include "smseg/synth/synth.hpp"

namespace {

namespace fs = std::filesystem;
using namespace smseg::sequence;
namespace sy = smseg::synth;
using Eigen::Vector3d;

sy::SynthOptions small(const std::string& scene, int frames = 24) {
  sy::SynthOptions o;
  o.scene = scene;
  o.width = 160;
  o.height = 120;
  o.frames = frames;
  return o;
}

fs::path temp_dir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / ("smseg_test_synth_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(p);
  return p;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

Vector3d centre(const Pose& p) { return {p.t[0], p.t[1], p.t[2]}; }

class SynthScenes : public ::testing::TestWithParam<std::string> {};

// Floor and ceiling pixels: the stored depth equals the analytic intersection of the pixel's ray with
// the plane y = 0 (floor) or y = ceiling height, computed here from the pose alone.
TEST_P(SynthScenes, FloorAndCeilingDepthMatchAnalyticPlanes) {
  const auto o = small(GetParam());
  const sy::Scene scene = sy::build_scene(o);
  int floor_checked = 0, ceiling_checked = 0;
  for (int f : {0, 11, 23}) {
    const sy::Frame fr = sy::render_frame(scene, o, f);
    const Vector3d C = centre(fr.pose);
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x) {
        const int label = fr.labels.at<std::uint8_t>(y, x);
        if (label != sy::kFloor && label != sy::kCeiling) continue;
        const Vector3d d = sy::pixel_ray(o, fr.pose, x, y);
        const double plane = label == sy::kFloor ? 0.0 : scene.ceiling_height;
        ASSERT_NE(d.y(), 0.0);
        const double lambda = (plane - C.y()) / d.y();
        ASSERT_GT(lambda, 0) << "frame " << f << " pixel " << x << "," << y << " looks away from its plane";
        if (label == sy::kFloor) {
          EXPECT_NEAR(fr.depth.at<float>(y, x), lambda, 1e-5 * lambda + 1e-6)
              << "frame " << f << " pixel " << x << "," << y;
        } else {  // ceiling, or a light panel hanging 4 mm below it
          const double lambda_panel = (plane - 0.005 - C.y()) / d.y();
          EXPECT_LE(fr.depth.at<float>(y, x), lambda * (1 + 1e-5)) << "frame " << f << " pixel " << x << "," << y;
          EXPECT_GE(fr.depth.at<float>(y, x), lambda_panel * (1 - 1e-5)) << "frame " << f << " pixel " << x << "," << y;
        }
        (label == sy::kFloor ? floor_checked : ceiling_checked)++;
      }
  }
  EXPECT_GT(floor_checked, 3000);
  EXPECT_GT(ceiling_checked, 200);
}

// The renderer's binned fast path gives exactly what the brute-force ray caster gives.
TEST_P(SynthScenes, RenderedDepthAndLabelsEqualBruteForceRayCast) {
  const auto o = small(GetParam());
  const sy::Scene scene = sy::build_scene(o);
  std::mt19937 rng(7);
  int hits = 0;
  for (int f : {0, 5, 17}) {
    const sy::Frame fr = sy::render_frame(scene, o, f);
    const auto quads = sy::quads_at(scene, sy::frame_time(o, f));
    const Vector3d C = centre(fr.pose);
    for (int k = 0; k < 400; ++k) {
      const int x = static_cast<int>(rng() % o.width), y = static_cast<int>(rng() % o.height);
      const sy::RayHit h = sy::cast_ray(quads, C, sy::pixel_ray(o, fr.pose, x, y));
      ASSERT_TRUE(h.hit) << "pixel " << x << "," << y << " sees nothing: the scene is not closed";
      EXPECT_EQ(fr.labels.at<std::uint8_t>(y, x), h.cls) << "frame " << f << " pixel " << x << "," << y;
      EXPECT_EQ(fr.depth.at<float>(y, x), static_cast<float>(h.lambda)) << "frame " << f << " pixel " << x << "," << y;
      ++hits;
    }
  }
  EXPECT_EQ(hits, 1200);
}

// The pixel straight below the principal point at the bottom of the image (floor ~2 m ahead) sees the
// floor: the robot keeps furniture and obstacles out of its way ahead; only a person crossing in front,
// or the far wall of a corridor junction while turning, may take its place.
TEST_P(SynthScenes, FloorUnderTheCameraIsLabelledFloor) {
  sy::SynthOptions o = small(GetParam(), 300);
  const sy::Scene scene = sy::build_scene(o);
  int floor = 0;
  for (int f = 0; f < o.frames; ++f) {
    const Pose pose = sy::camera_pose(scene, o, f);
    const auto quads = sy::quads_at(scene, sy::frame_time(o, f));
    const sy::RayHit h = sy::cast_ray(quads, centre(pose), sy::pixel_ray(o, pose, o.cx(), o.height - 1));
    ASSERT_TRUE(h.hit);
    EXPECT_TRUE(h.cls == sy::kFloor || h.cls == sy::kPerson || h.cls == sy::kWall)
        << "frame " << f << ": class " << int(h.cls);
    if (h.cls == sy::kFloor) {
      EXPECT_NEAR(h.point.y(), 0.0, 1e-9);
      ++floor;
    }
  }
  EXPECT_GE(floor, 255) << "of 300 frames";
  // And in rendered frames (the image path).
  o.frames = 24;
  const sy::Scene s2 = sy::build_scene(o);
  for (int f : {0, 23}) {
    const sy::Frame fr = sy::render_frame(s2, o, f);
    EXPECT_EQ(fr.labels.at<std::uint8_t>(o.height - 1, static_cast<int>(std::lround(o.cx()))), sy::kFloor);
  }
}

// Stereo: a textured patch of the left image matches the right image best at (within a pixel of) the
// ground-truth disparity fx * B / Z.
TEST_P(SynthScenes, RightImageMatchesAtGroundTruthDisparity) {
  const auto o = small(GetParam());
  const sy::Scene scene = sy::build_scene(o);
  const double fx = o.fx();
  int tested = 0, good = 0;
  for (int f : {0, 6, 12, 18, 23}) {
    const sy::Frame fr = sy::render_frame(scene, o, f);
    cv::Mat L, R;
    cv::cvtColor(fr.left, L, cv::COLOR_BGR2GRAY);
    cv::cvtColor(fr.right, R, cv::COLOR_BGR2GRAY);
    L.convertTo(L, CV_32F);
    R.convertTo(R, CV_32F);
    cv::Mat gx;
    cv::Sobel(L, gx, CV_32F, 1, 0);
    gx = cv::abs(gx);
    const int r = 4;
    for (int y = r + 2; y < o.height - r - 2; y += 3)
      for (int x = 40; x < o.width - r - 2; x += 3) {
        const cv::Rect win(x - r, y - r, 2 * r + 1, 2 * r + 1);
        // Horizontal texture (a horizontal edge alone says nothing about disparity).
        if (cv::mean(gx(win))[0] < 15.0) continue;
        const float z = fr.depth.at<float>(y, x);
        ASSERT_GT(z, 0);
        const double d_gt = fx * o.baseline / z;
        if (x - r - d_gt - 3 < 0) continue;
        // Depth must be nearly constant in the window (no occlusion boundary).
        double zmin, zmax;
        cv::minMaxLoc(fr.depth(win), &zmin, &zmax);
        if (zmax - zmin > 0.05 * z) continue;
        const int dmax = std::min(x - r, static_cast<int>(d_gt) + 8);
        double best = 1e300;
        int best_d = -1;
        for (int d = 0; d <= dmax; ++d) {
          const double ssd = cv::norm(L(win), R(cv::Rect(x - r - d, y - r, 2 * r + 1, 2 * r + 1)), cv::NORM_L2SQR);
          if (ssd < best) {
            best = ssd;
            best_d = d;
          }
        }
        ++tested;
        if (std::abs(best_d - d_gt) <= 1.0) ++good;

      }
  }
  EXPECT_GT(tested, 60);
  EXPECT_GT(good, 0.9 * tested) << good << " of " << tested << " textured patches match within 1 px";
}

// The static-world assumption is broken: people are seen, and they move.
TEST_P(SynthScenes, PeopleAreSeenAndMove) {
  const auto o = small(GetParam(), 300);
  const sy::Scene scene = sy::build_scene(o);
  ASSERT_FALSE(scene.people.empty());
  int frames_with_person = 0;
  for (int f = 0; f < o.frames; f += 5) {
    const Pose pose = sy::camera_pose(scene, o, f);
    const auto quads = sy::quads_at(scene, sy::frame_time(o, f));
    bool seen = false;
    for (int y = 4; y < o.height && !seen; y += 8)
      for (int x = 4; x < o.width && !seen; x += 8)
        seen = sy::cast_ray(quads, centre(pose), sy::pixel_ray(o, pose, x, y)).cls == sy::kPerson;
    frames_with_person += seen;
  }
  EXPECT_GE(frames_with_person, 6) << "of 60 sampled frames";
  const auto q0 = sy::quads_at(scene, 0.0), q1 = sy::quads_at(scene, 1.0);
  ASSERT_EQ(q0.size(), q1.size());
  ASSERT_GT(q0.size(), scene.quads.size());
  const std::size_t i = scene.quads.size();  // the first person's first body part
  EXPECT_EQ(q0[i].cls, sy::kPerson);
  EXPECT_GT((q0[i].centre - q1[i].centre).norm(), 0.5) << "a person walks ~1 m/s";
}

INSTANTIATE_TEST_SUITE_P(Scenes, SynthScenes, ::testing::Values("corridor", "lab"));

TEST(Synth, CastRayAgainstHandBuiltQuads) {
  std::vector<sy::Quad> quads(2);
  // A 2 x 1 m quad in the plane z = 5 facing -z (towards the origin), centred at (0, 0, 5).
  quads[0].centre = {0, 0, 5};
  quads[0].u = {-1, 0, 0};
  quads[0].v = {0, 1, 0};
  quads[0].normal = quads[0].u.cross(quads[0].v);
  ASSERT_NEAR(quads[0].normal.z(), -1.0, 1e-12);
  quads[0].hu = 1.0;
  quads[0].hv = 0.5;
  quads[0].cls = sy::kWall;
  // A smaller quad in front of it at z = 3, covering x in [0.5, 1.5].
  quads[1] = quads[0];
  quads[1].centre = {1.0, 0, 3};
  quads[1].hu = 0.5;
  quads[1].cls = sy::kObstacle;
  const Vector3d o(0, 0, 0);
  sy::RayHit h = sy::cast_ray(quads, o, Vector3d(0.1, 0.05, 1.0));
  ASSERT_TRUE(h.hit);
  EXPECT_DOUBLE_EQ(h.lambda, 5.0);
  EXPECT_EQ(h.cls, sy::kWall);
  EXPECT_NEAR((h.point - Vector3d(0.5, 0.25, 5.0)).norm(), 0.0, 1e-12);
  h = sy::cast_ray(quads, o, Vector3d(0.3, 0.0, 1.0));  // x = 0.9 at z = 3: the nearer quad
  ASSERT_TRUE(h.hit);
  EXPECT_DOUBLE_EQ(h.lambda, 3.0);
  EXPECT_EQ(h.cls, sy::kObstacle);
  EXPECT_EQ(h.quad, 1);
  EXPECT_FALSE(sy::cast_ray(quads, o, Vector3d(0.3, 0.2, 1.0)).hit);  // y = 1.0 at z = 5: above both
  EXPECT_FALSE(sy::cast_ray(quads, o, Vector3d(0, 0, -1)).hit);       // looking away
  // One-sided: from behind (z = 10 looking back) nothing is hit.
  EXPECT_FALSE(sy::cast_ray(quads, Vector3d(0, 0, 10), Vector3d(0, 0, -1)).hit);
  // Unnormalised direction: lambda is in units of the direction.
  h = sy::cast_ray(quads, o, Vector3d(0, 0, 2.0));
  EXPECT_DOUBLE_EQ(h.lambda, 2.5);
}

TEST(Synth, PosesFollowTheWorldConvention) {
  auto o = small("corridor", 300);
  const sy::Scene scene = sy::build_scene(o);
  const Pose p0 = sy::camera_pose(scene, o, 0);
  EXPECT_NEAR(p0.t[0], 0.0, 1e-9);
  EXPECT_NEAR(p0.t[2], 0.0, 1e-9);
  EXPECT_NEAR(p0.t[1], o.camera_y(), 0.01);
  double yaw0 = 0;
  int phase = 0;  // 0: before the first turn, 1: turned ~90 degrees, 2: turned back
  double travelled = 0;
  for (int f = 0; f < o.frames; ++f) {
    const Pose p = sy::camera_pose(scene, o, f);
    const Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>> R(p.R.data());
    EXPECT_NEAR((R * R.transpose() - Eigen::Matrix3d::Identity()).norm(), 0.0, 1e-9);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-9);
    EXPECT_LT(R(1, 2), 0.05) << "the camera looks roughly horizontally";
    EXPECT_GT(R(1, 1), -1.01);
    EXPECT_LT(R(1, 1), -0.99) << "camera y (down) is world -Y";
    const double yaw = std::atan2(R(0, 2), R(2, 2));
    if (f == 0) yaw0 = yaw;
    double rel = std::abs(yaw - yaw0);
    rel = std::min(rel, 2 * M_PI - rel);
    if (phase == 0 && rel > 75 * M_PI / 180) phase = 1;
    if (phase == 1 && rel < 15 * M_PI / 180) phase = 2;
    if (f > 0) {
      const Pose q = sy::camera_pose(scene, o, f - 1);
      const double step = std::hypot(p.t[0] - q.t[0], p.t[2] - q.t[2]);
      EXPECT_LT(step * o.fps, 1.0) << "smooth motion, frame " << f;
      travelled += step;
    }
  }
  EXPECT_EQ(phase, 2) << "the corridor path takes two turns within 300 frames";
  EXPECT_GT(travelled / (o.frames / o.fps), 0.3);
  EXPECT_LT(travelled / (o.frames / o.fps), 0.6);
}

TEST(Synth, WritesAValidSequence) {
  const fs::path dir = temp_dir("valid");
  auto o = small("lab", 21);
  const Sequence seq = sy::make_sequence(o, dir);
  const Sequence again = load_sequence(dir);
  EXPECT_NO_THROW(validate_images(again));
  EXPECT_EQ(again.frame_count(), 21);
  EXPECT_EQ(again.labelled_frames, (std::vector<int>{0, 10, 20}));
  ASSERT_EQ(again.classes.size(), 6u);
  const char* names[] = {"floor", "wall", "ceiling", "furniture", "obstacle", "person"};
  for (int c = 0; c < 6; ++c) EXPECT_EQ(again.classes[c].name, names[c]);
  EXPECT_EQ(again.kind, SequenceKind::Stereo);
  EXPECT_EQ(again.size, cv::Size(160, 120));
  EXPECT_NEAR(*again.calibration.fx, o.fx(), 1e-9);
  EXPECT_NEAR(*again.calibration.baseline, 0.12, 1e-12);
  EXPECT_NEAR(*again.camera_height, 1.0, 1e-12);
  ASSERT_EQ(again.gt_poses.size(), 21u);
  EXPECT_NEAR(again.frames[12].time, 1.0, 1e-12);
  EXPECT_EQ(again.extra["scene"], "lab");
  // Every frame has labels and depth; nothing is void.
  for (int f = 0; f < again.frame_count(); f += 5) {
    const cv::Mat labels = again.load_labels(f);
    EXPECT_EQ(cv::countNonZero(labels == kVoid), 0);
    const cv::Mat depth = again.load_gt_depth(f);
    double lo, hi;
    cv::minMaxLoc(depth, &lo, &hi);
    EXPECT_GT(lo, 0.0);
    EXPECT_LT(hi, 30.0);
  }
  // The stored labels and depth are the rendered ones.
  const sy::Frame fr = sy::render_frame(sy::build_scene(o), o, 10);
  EXPECT_EQ(cv::countNonZero(again.load_labels(10) != fr.labels), 0);
  EXPECT_EQ(cv::norm(again.load_gt_depth(10), fr.depth, cv::NORM_INF), 0.0);
  // Montage: header + one row per frame, three columns.
  const cv::Mat m = sy::make_montage(again, {0, 20});
  EXPECT_EQ(m.cols, 3 * 160 + 2 * 4);
  EXPECT_EQ(m.rows, 22 + 2 * (120 + 4));
  fs::remove_all(dir);
}

namespace {

// Every file under a exists under b with the same bytes; returns how many files a holds.
int expect_same_files(const fs::path& a, const fs::path& b) {
  int files = 0;
  for (const auto& e : fs::recursive_directory_iterator(a)) {
    if (!e.is_regular_file()) continue;
    const fs::path rel = fs::relative(e.path(), a);
    if (!fs::exists(b / rel)) {
      ADD_FAILURE() << rel << " is missing from the second run";
    } else {
      EXPECT_EQ(slurp(e.path()), slurp(b / rel)) << rel << " differs between runs";
    }
    ++files;
  }
  return files;
}

}  // namespace

TEST(Synth, SameSeedSameBytesWhateverTheThreadCount) {
  const fs::path a = temp_dir("det_a"), b = temp_dir("det_b"), c = temp_dir("det_c");
  auto o = small("corridor", 8);
  o.seed = 3;
  sy::make_sequence(o, a);
  tbb::task_arena one(1);
  one.execute([&] { sy::make_sequence(o, b); });
  const int files = expect_same_files(a, b);
  EXPECT_EQ(files, 1 + 4 * 8);
  o.seed = 4;
  sy::make_sequence(o, c);
  EXPECT_NE(slurp(a / "left/000000.png"), slurp(c / "left/000000.png"));
  EXPECT_NE(slurp(a / "right/000005.png"), slurp(c / "right/000005.png"));
  for (const auto& d : {a, b, c}) fs::remove_all(d);
}

TEST(Synth, NoiseIsPerCameraAndFrame) {
  auto o = small("lab", 4);
  o.noise_sigma = 0;
  const sy::Scene scene = sy::build_scene(o);
  const sy::Frame clean = sy::render_frame(scene, o, 2);
  o.noise_sigma = 3;
  const sy::Frame noisy = sy::render_frame(scene, o, 2);
  cv::Mat diff;
  cv::subtract(noisy.left, clean.left, diff, cv::noArray(), CV_32F);
  cv::Scalar mean, sd;
  cv::meanStdDev(diff.reshape(1), mean, sd);
  EXPECT_NEAR(mean[0], 0.0, 0.3);
  EXPECT_GT(sd[0], 2.5);  // read noise 3 plus some shot noise, minus clipping
  EXPECT_LT(sd[0], 4.5);
  EXPECT_EQ(cv::countNonZero(noisy.labels != clean.labels), 0);
}

TEST(Synth, BadOptionsNameTheOption) {
  auto expect_bad = [](const std::string& field, auto mutate) {
    sy::SynthOptions o;
    mutate(o);
    try {
      o.validate();
      ADD_FAILURE() << "no error for a bad " << field;
    } catch (const smseg::Error& e) {
      EXPECT_EQ(e.field(), field) << e.what();
    }
    EXPECT_THROW(sy::build_scene(o), smseg::Error);
  };
  expect_bad("scene", [](auto& o) { o.scene = "garden"; });
  expect_bad("frames", [](auto& o) { o.frames = 0; });
  expect_bad("width", [](auto& o) { o.width = 8; });
  expect_bad("height", [](auto& o) { o.height = 100000; });
  expect_bad("label_every", [](auto& o) { o.label_every = 0; });
  expect_bad("fps", [](auto& o) { o.fps = -1; });
  expect_bad("baseline", [](auto& o) { o.baseline = 0; });
  expect_bad("camera_height", [](auto& o) { o.camera_height = 5; });
  expect_bad("hfov_deg", [](auto& o) { o.hfov_deg = 179; });
  expect_bad("speed", [](auto& o) { o.speed = std::nan(""); });
  expect_bad("noise_sigma", [](auto& o) { o.noise_sigma = -1; });
  EXPECT_NO_THROW(sy::SynthOptions{}.validate());
  const sy::Scene scene = sy::build_scene(small("lab", 5));
  EXPECT_THROW(sy::camera_pose(scene, small("lab", 5), 5), smseg::Error);
}

}  // namespace

// ---------------------------------------------------------------------------------------------------
// The tabletop scene: a table with 3-6 objects, the camera circling it, instance images.

namespace {

sy::SynthOptions tabletop(std::uint64_t seed, int frames) {
  sy::SynthOptions o = small("tabletop", frames);
  o.seed = seed;
  return o;
}

/// True when world point p lies inside object ob (its box or cylinder), grown by tol metres.
bool inside_object(const sy::Object& ob, const Vector3d& p, double tol) {
  const Vector3d r = p - ob.base;
  if (r.y() < -tol || r.y() > ob.size.y() + tol) return false;
  if (ob.shape == "cylinder") return std::hypot(r.x(), r.z()) <= ob.size.x() / 2 + tol;
  // Box turned by yaw: local x = (cos, 0, -sin), local z = (sin, 0, cos).
  const double lx = r.x() * std::cos(ob.yaw) - r.z() * std::sin(ob.yaw);
  const double lz = r.x() * std::sin(ob.yaw) + r.z() * std::cos(ob.yaw);
  return std::abs(lx) <= ob.size.x() / 2 + tol && std::abs(lz) <= ob.size.z() / 2 + tol;
}

}  // namespace

// The layout: 3-6 distinct objects standing on the table top, inside its edges and not overlapping.
TEST(SynthTabletop, ObjectsStandOnTheTableApart) {
  for (std::uint64_t seed : {1, 2, 3, 4, 5, 6}) {
    const sy::Scene scene = sy::build_scene(tabletop(seed, 2));
    ASSERT_GE(scene.objects.size(), 3u) << "seed " << seed;
    ASSERT_LE(scene.objects.size(), 6u) << "seed " << seed;
    std::set<std::string> colours;
    for (std::size_t i = 0; i < scene.objects.size(); ++i) {
      const sy::Object& a = scene.objects[i];
      EXPECT_EQ(a.id, static_cast<int>(i) + 1);
      EXPECT_NEAR(a.base.y(), sy::kTableHeight, 1e-12);
      EXPECT_LE(std::hypot(a.base.x() - scene.look_at.x(), a.base.z() - scene.look_at.z()), 0.6) << "seed " << seed;
      EXPECT_TRUE(colours.insert(a.colour).second) << "seed " << seed << ": two " << a.colour << " objects";
      for (std::size_t j = 0; j < i; ++j) {
        const sy::Object& b = scene.objects[j];
        const double gap = std::hypot(a.base.x() - b.base.x(), a.base.z() - b.base.z()) -
                           0.5 * std::hypot(a.size.x(), a.size.z()) - 0.5 * std::hypot(b.size.x(), b.size.z());
        EXPECT_GE(gap, 0.05) << "seed " << seed << ": objects " << a.id << " and " << b.id << " touch";
      }
    }
  }
}

// The renderer's fast path (with the cylinders' disc lids) equals the brute-force ray caster, instance
// ids included, and every object pixel's 3D point lies on its object.
TEST(SynthTabletop, InstancesAgreeWithRayCastAndObjectGeometry) {
  const auto o = tabletop(2, 24);
  const sy::Scene scene = sy::build_scene(o);
  const auto quads = sy::quads_at(scene, 0.0);
  std::mt19937 rng(11);
  int object_pixels = 0, cast = 0;
  for (int f : {0, 9, 23}) {
    const sy::Frame fr = sy::render_frame(scene, o, f);
    const Vector3d C = centre(fr.pose);
    for (int k = 0; k < 300; ++k) {
      const int x = static_cast<int>(rng() % o.width), y = static_cast<int>(rng() % o.height);
      const sy::RayHit h = sy::cast_ray(quads, C, sy::pixel_ray(o, fr.pose, x, y));
      ASSERT_TRUE(h.hit) << "pixel " << x << "," << y << " sees nothing: the room is not closed";
      EXPECT_EQ(fr.labels.at<std::uint8_t>(y, x), h.cls) << "frame " << f << " pixel " << x << "," << y;
      EXPECT_EQ(fr.instances.at<std::uint8_t>(y, x), quads[h.quad].instance) << "frame " << f;
      EXPECT_EQ(fr.depth.at<float>(y, x), static_cast<float>(h.lambda));
      ++cast;
    }
    for (int y = 0; y < o.height; ++y)
      for (int x = 0; x < o.width; ++x) {
        const int id = fr.instances.at<std::uint8_t>(y, x);
        ASSERT_EQ(id != 0, fr.labels.at<std::uint8_t>(y, x) == sy::kObject) << "pixel " << x << "," << y;
        if (id == 0) continue;
        ASSERT_LE(id, static_cast<int>(scene.objects.size()));
        const Vector3d p = C + fr.depth.at<float>(y, x) * sy::pixel_ray(o, fr.pose, x, y);
        EXPECT_TRUE(inside_object(scene.objects[id - 1], p, 0.005))
            << "frame " << f << " pixel " << x << "," << y << " of object " << id << " is off the object";
        ++object_pixels;
      }
  }
  EXPECT_EQ(cast, 900);
  EXPECT_GT(object_pixels, 300);
}

// The camera circles the table at about the table top + 0.4 m, always moving, looking down at the table;
// every object is seen (at least 15 pixels at 160x120) in most frames.
TEST(SynthTabletop, CameraCirclesTheTableAndSeesTheObjects) {
  for (std::uint64_t seed : {1, 3}) {
    const auto o = tabletop(seed, 120);
    const sy::Scene scene = sy::build_scene(o);
    const int K = static_cast<int>(scene.objects.size());
    std::vector<int> seen(K + 1, 0);
    int frames = 0;
    double travelled = 0, turned = 0;
    Eigen::Vector2d prev_dir(0, 0);
    for (int f = 0; f < o.frames; ++f) {
      const Pose p = sy::camera_pose(scene, o, f);
      EXPECT_NEAR(p.t[1], sy::kTableHeight + 0.4, 0.01);
      const Eigen::Vector2d rel(p.t[0] - scene.look_at.x(), p.t[2] - scene.look_at.z());
      EXPECT_GT(rel.norm(), 1.1) << "seed " << seed << " frame " << f;
      EXPECT_LT(rel.norm(), 1.9) << "seed " << seed << " frame " << f;
      EXPECT_LT(p.R[5], -0.1) << "the optical axis (R column 2) points down";
      if (f > 0) {
        const Pose q = sy::camera_pose(scene, o, f - 1);
        const double step = std::hypot(p.t[0] - q.t[0], p.t[2] - q.t[2]);
        EXPECT_GT(step, 0.01) << "seed " << seed << " frame " << f << ": the camera stands still";
        EXPECT_LT(step, 0.08) << "seed " << seed << " frame " << f;
        travelled += step;
        turned += std::abs(std::atan2(prev_dir.x() * rel.y() - prev_dir.y() * rel.x(), prev_dir.dot(rel)));
      }
      prev_dir = rel;
      if (f % 4 != 0) continue;
      const sy::Frame fr = sy::render_frame(scene, o, f);
      for (int id = 1; id <= K; ++id) seen[id] += cv::countNonZero(fr.instances == id) >= 15;
      ++frames;
    }
    for (int id = 1; id <= K; ++id)
      EXPECT_GE(seen[id], 0.8 * frames) << "seed " << seed << ": object " << id << " seen in " << seen[id] << " of "
                                        << frames << " frames";
    EXPECT_GT(travelled / (o.frames / o.fps), 0.3);
    EXPECT_GT(turned, 0.5) << "the camera moves around the table";
  }
}

// The written sequence: tabletop classes, an instance image for every labelled frame (and only those),
// object pixels exactly the pixels labelled object, the object list in the manifest.
TEST(SynthTabletop, WritesAValidSequenceWithInstanceImages) {
  const fs::path dir = temp_dir("tabletop");
  auto o = tabletop(4, 13);
  o.label_every = 6;
  sy::make_sequence(o, dir);
  const Sequence seq = load_sequence(dir);
  EXPECT_NO_THROW(validate_images(seq));
  ASSERT_EQ(seq.classes.size(), 5u);
  const char* names[] = {"floor", "wall", "ceiling", "table", "object"};
  for (int c = 0; c < 5; ++c) EXPECT_EQ(seq.classes[c].name, names[c]);
  EXPECT_NEAR(*seq.camera_height, 1.15, 1e-12);
  EXPECT_EQ(seq.labelled_frames, (std::vector<int>{0, 6, 12}));
  const int K = static_cast<int>(seq.extra["objects"].size());
  EXPECT_GE(K, 3);
  for (int f = 0; f < seq.frame_count(); ++f) {
    EXPECT_EQ(seq.has_instances(f), f % 6 == 0) << "frame " << f;
    if (!seq.has_instances(f)) continue;
    const cv::Mat inst = seq.load_instances(f), labels = seq.load_labels(f);
    EXPECT_EQ(cv::countNonZero((inst > 0) != (labels == sy::kObject)), 0) << "frame " << f;
    double lo, hi;
    cv::minMaxLoc(inst, &lo, &hi);
    EXPECT_LE(hi, K);
    EXPECT_GT(cv::countNonZero(labels == sy::kTable), 500) << "frame " << f;
    EXPECT_EQ(cv::countNonZero(labels == kVoid), 0) << "frame " << f;
  }
  // Other scenes have no instance images, and asking for one is an error naming the field.
  const fs::path lab = temp_dir("lab_noinst");
  sy::make_sequence(small("lab", 2), lab);
  const Sequence ls = load_sequence(lab);
  EXPECT_FALSE(ls.has_instances(0));
  EXPECT_FALSE(fs::exists(lab / "instances"));
  try {
    ls.load_instances(0);
    ADD_FAILURE() << "no error";
  } catch (const smseg::Error& e) {
    EXPECT_NE(std::string(e.what()).find("instances"), std::string::npos) << e.what();
  }
  fs::remove_all(dir);
  fs::remove_all(lab);
}

TEST(SynthTabletop, SameSeedSameBytesWhateverTheThreadCount) {
  const fs::path a = temp_dir("tt_a"), b = temp_dir("tt_b"), c = temp_dir("tt_c");
  auto o = tabletop(7, 5);
  o.label_every = 2;
  sy::make_sequence(o, a);
  tbb::task_arena one(1);
  one.execute([&] { sy::make_sequence(o, b); });
  const int files = expect_same_files(a, b);
  EXPECT_EQ(files, 1 + 4 * 5 + 3);  // manifest, 4 files per frame, instances of frames 0, 2, 4
  o.seed = 8;
  sy::make_sequence(o, c);
  EXPECT_NE(slurp(a / "left/000000.png"), slurp(c / "left/000000.png"));
  EXPECT_NE(slurp(a / "sequence.json"), slurp(c / "sequence.json"));
  for (const auto& d : {a, b, c}) fs::remove_all(d);
}
