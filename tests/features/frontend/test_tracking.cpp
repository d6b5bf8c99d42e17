// Keypoint matching, track chaining, the filters, and the whole stereo front end on a small synthetic
// stereo video (a textured wall seen by a camera sliding sideways), plus the tracks file.
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <string>

#include <unistd.h>

#include <oneapi/tbb/global_control.h>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "random_texture.hpp"
#include "smseg/frontend/motion.hpp"
#include "smseg/frontend/tracks_io.hpp"
#include "smseg/frontend/tracking.hpp"

namespace fs = std::filesystem;
using namespace smseg;
using namespace smseg::sequence;
using namespace smseg::frontend;

namespace {

cv::Mat texture(int w, int h, std::uint64_t seed) { return test::random_texture(w, h, seed, 1.5, 0, 255); }

cv::Mat shifted(const cv::Mat& tex, int W, int H, double sx, double sy) {
  cv::Mat mx(H, W, CV_32FC1), my(H, W, CV_32FC1);
  for (int y = 0; y < H; ++y)
    for (int x = 0; x < W; ++x) mx.at<float>(y, x) = static_cast<float>(x + sx), my.at<float>(y, x) = static_cast<float>(y + sy);
  cv::Mat out, out8;
  cv::remap(tex, out, mx, my, cv::INTER_LINEAR, cv::BORDER_REFLECT);
  out.convertTo(out8, CV_8U);
  return out8;
}

FrameObservations frame(std::vector<float> disparities, std::vector<int> labels = {}) {
  FrameObservations f;
  for (std::size_t i = 0; i < disparities.size(); ++i) {
    f.pixels.emplace_back(static_cast<float>(i), 0.f);
    f.disparities.push_back(disparities[i]);
    f.points.emplace_back(0, 0, disparities[i] > 0 ? 10.0 / disparities[i] : 0);
  }
  f.labels = labels.empty() ? std::vector<int>(disparities.size(), -1) : labels;
  return f;
}

}  // namespace

TEST(Tracking, SymmetricMatchingDropsAsymmetricMatches) {
  // a2's nearest is b1, but b1's nearest is a1: (2, 1) is not symmetric and must go.
  const cv::Mat a = (cv::Mat_<float>(3, 2) << 0, 0, 10, 0, 11, 0);
  const cv::Mat b = (cv::Mat_<float>(2, 2) << 1, 0, 10.4f, 0);
  const auto m = match_symmetric(a, b, cv::NORM_L2);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].queryIdx, 0);
  EXPECT_EQ(m[0].trainIdx, 0);
  EXPECT_EQ(m[1].queryIdx, 1);
  EXPECT_EQ(m[1].trainIdx, 1);
  EXPECT_NEAR(m[1].distance, 0.4, 1e-5);
  // Binary descriptors with Hamming distance.
  const cv::Mat ha = (cv::Mat_<std::uint8_t>(2, 1) << 0b00001111, 0b11110000);
  const cv::Mat hb = (cv::Mat_<std::uint8_t>(2, 1) << 0b11100000, 0b00000111);
  const auto hm = match_symmetric(ha, hb, cv::NORM_HAMMING);
  ASSERT_EQ(hm.size(), 2u);
  EXPECT_EQ(hm[0].trainIdx, 1);
  EXPECT_EQ(hm[1].trainIdx, 0);
  EXPECT_TRUE(match_symmetric(cv::Mat(), b, cv::NORM_L2).empty());
  EXPECT_THROW(match_symmetric(a, cv::Mat_<float>(1, 3, 0.f), cv::NORM_L2), Error);
}

TEST(Tracking, ChainsFollowMatches) {
  // 3 frames of 2 keypoints: f0k0 -> f1k1 -> f2k0; f1k0 -> f2k1; f0k1 ends.
  const std::vector<std::vector<cv::DMatch>> m = {{cv::DMatch(0, 1, 0.f)}, {cv::DMatch(1, 0, 0.f), cv::DMatch(0, 1, 0.f)}};
  int n = 0;
  const auto id = chain_matches({2, 2, 2}, m, &n);
  EXPECT_EQ(n, 3);
  EXPECT_EQ(id[0], (std::vector<int>{0, 1}));
  EXPECT_EQ(id[1], (std::vector<int>{2, 0}));
  EXPECT_EQ(id[2], (std::vector<int>{0, 2}));
  // A keypoint matched twice is a bug in the matcher: reported, not silently merged.
  const std::vector<std::vector<cv::DMatch>> dup = {{cv::DMatch(0, 0, 0.f), cv::DMatch(1, 0, 0.f)}};
  EXPECT_THROW(chain_matches({2, 2}, dup, nullptr), Error);
}

TEST(Tracking, EachFilterCountsWhatItRemoved) {
  // 4 frames, 4 keypoints each, matched straight through (k -> k): tracks 0..3 when nothing breaks.
  // Frame 1 is labelled. Track 0: all valid, label 2 in frame 1 -> kept.
  // Track 1: disparity invalid everywhere except frame 2 -> 3 observations removed, then too short.
  // Track 2: valid, but its pixel is void in frame 1 -> never labelled.
  // Track 3: labels 1 in frame 1 and 2 in frame 3 (frame 3 labelled too) -> inconsistent.
  std::vector<FrameObservations> f = {
      frame({5, -1, 5, 5}),
      frame({5, -1, 5, 5}, {2, -1, -1, 1}),
      frame({5, 5, 5, 5}),
      frame({5, -1, 5, 5}, {2, -1, -1, 2}),
  };
  std::vector<std::vector<cv::DMatch>> m(3);
  for (auto& pair : m)
    for (int k = 0; k < 4; ++k) pair.emplace_back(k, k, 0.f);
  FilterCounts c;
  std::vector<Track> after1;
  const auto kept = build_tracks(f, m, TrackFilterOptions{}, c, &after1);
  EXPECT_EQ(c.observations, 16);
  EXPECT_EQ(c.tracks, 4);
  EXPECT_EQ(c.removed_no_disparity_obs, 3);
  EXPECT_EQ(c.removed_no_disparity_tracks, 0);
  EXPECT_EQ(c.removed_short_tracks, 1);
  EXPECT_EQ(c.removed_short_obs, 1);
  EXPECT_EQ(c.unlabelled_tracks, 1);  // counted, not removed without require_label
  EXPECT_FALSE(c.unlabelled_removed);
  EXPECT_EQ(c.removed_inconsistent_tracks, 1);  // counted, not removed without require_label
  EXPECT_EQ(c.removed_inconsistent_obs, 4);
  EXPECT_FALSE(c.inconsistent_removed);
  EXPECT_EQ(c.kept_tracks, 3);
  EXPECT_EQ(c.kept_obs, 12);
  ASSERT_EQ(kept.size(), 3u);
  EXPECT_EQ(kept[0].label, 2);
  EXPECT_EQ(kept[0].labels, (std::vector<int>{-1, 2, -1, 2}));
  EXPECT_EQ(kept[1].label, -1);
  EXPECT_EQ(kept[2].label, -1);  // inconsistent: kept without a class of its own
  EXPECT_EQ(after1.size(), 4u);
  EXPECT_EQ(after1[1].frames, (std::vector<int>{2}));

  TrackFilterOptions training;
  training.require_label = true;
  const auto kept_t = build_tracks(f, m, training, c);
  EXPECT_EQ(c.unlabelled_tracks, 1);
  EXPECT_TRUE(c.unlabelled_removed);
  EXPECT_TRUE(c.inconsistent_removed);
  EXPECT_EQ(c.kept_tracks, 1);
  ASSERT_EQ(kept_t.size(), 1u);
  EXPECT_EQ(kept_t[0].label, 2);

  // A gap: frames 0 and 2 valid, 1 invalid -> one track with frames {0, 2}.
  std::vector<FrameObservations> g = {frame({5}), frame({-1}), frame({5})};
  std::vector<std::vector<cv::DMatch>> gm = {{cv::DMatch(0, 0, 0.f)}, {cv::DMatch(0, 0, 0.f)}};
  const auto gap = build_tracks(g, gm, TrackFilterOptions{}, c);
  ASSERT_EQ(gap.size(), 1u);
  EXPECT_EQ(gap[0].frames, (std::vector<int>{0, 2}));
}

TEST(Tracking, BackProjectionFollowsThePinholeModel) {
  const Eigen::Vector3d p = backproject(200, 60, 10, 300, 310, 160, 120, 0.12);
  EXPECT_NEAR(p.z(), 300 * 0.12 / 10, 1e-12);
  EXPECT_NEAR(p.x(), 40 * p.z() / 300, 1e-12);
  EXPECT_NEAR(p.y(), -60 * p.z() / 310, 1e-12);
}

TEST(Tracking, KeypointsMatchAcrossAShiftedImage) {
  const cv::Mat tex = texture(400, 300, 11);
  const cv::Mat a = shifted(tex, 320, 240, 0, 0), b = shifted(tex, 320, 240, 5, 3);  // b(x) = a(x + (5, 3))
  for (KeypointMethod method : {KeypointMethod::Sift, KeypointMethod::Orb, KeypointMethod::Akaze}) {
    TrackingOptions o;
    o.detector = method;
    o.max_keypoints = 300;
    const FrameKeypoints ka = detect_keypoints(a, o), kb = detect_keypoints(b, o);
    ASSERT_GT(ka.keypoints.size(), 50u) << keypoint_method_name(method);
    EXPECT_LE(ka.keypoints.size(), 300u);
    const auto m = match_symmetric(ka.descriptors, kb.descriptors, descriptor_norm(method));
    int right = 0;
    for (const auto& d : m) {
      const cv::Point2f v = kb.keypoints[d.trainIdx].pt - ka.keypoints[d.queryIdx].pt;
      right += std::hypot(v.x + 5, v.y + 3) < 2.5;  // ORB positions on coarse levels are coarse
    }
    EXPECT_GT(m.size(), ka.keypoints.size() / 3) << keypoint_method_name(method);
    EXPECT_GT(right, 0.85 * m.size()) << keypoint_method_name(method);
    // Deterministic.
    const FrameKeypoints again = detect_keypoints(a, o);
    ASSERT_EQ(again.keypoints.size(), ka.keypoints.size());
    EXPECT_EQ(cv::norm(again.descriptors, ka.descriptors, cv::NORM_INF), 0);
  }
  // A blank image has no keypoints; that is not an error.
  EXPECT_TRUE(detect_keypoints(cv::Mat(240, 320, CV_8UC1, cv::Scalar(90)), TrackingOptions{}).keypoints.empty());
}

TEST(Tracking, DropFarMatchesAppliesBothLimits) {
  const std::vector<cv::Point2f> pa = {{0, 0}, {10, 10}, {20, 20}};
  const std::vector<cv::Point2f> pb = {{3, 4}, {10, 30}, {20, 21}};
  const std::vector<cv::DMatch> all = {{0, 0, 1.f}, {1, 1, 2.f}, {2, 2, 9.f}};
  TrackingOptions o;
  auto m = all;
  drop_far_matches(m, pa, pb, o);  // both limits off
  EXPECT_EQ(m.size(), 3u);
  o.max_pixel_motion = 5;  // (0,0)->(3,4) moves exactly 5: kept; 20 px: dropped
  m = all;
  drop_far_matches(m, pa, pb, o);
  ASSERT_EQ(m.size(), 2u);
  EXPECT_EQ(m[0].queryIdx, 0);
  EXPECT_EQ(m[1].queryIdx, 2);
  o.max_descriptor_distance = 5;
  drop_far_matches(m, pa, pb, o);
  ASSERT_EQ(m.size(), 1u);
  EXPECT_EQ(m[0].queryIdx, 0);
}

TEST(Tracking, GfttGivesCornersWithoutDescriptors) {
  const cv::Mat a = shifted(texture(400, 300, 11), 320, 240, 0, 0);
  TrackingOptions o;
  o.detector = KeypointMethod::Gftt;
  o.max_keypoints = 300;
  const FrameKeypoints k = detect_keypoints(a, o);
  EXPECT_EQ(k.keypoints.size(), 300u);
  EXPECT_TRUE(k.descriptors.empty());
  for (std::size_t i = 1; i < k.keypoints.size(); ++i) EXPECT_GE(k.keypoints[i - 1].response, k.keypoints[i].response);
  EXPECT_EQ(parse_keypoint_method("gftt"), KeypointMethod::Gftt);
  EXPECT_THROW(parse_keypoint_method("surf"), Error);
  o.gftt_quality = 0;
  EXPECT_THROW(o.validate(), Error);
}

TEST(Tracking, KltStepFollowsAShiftedImageAndFillsGaps) {
  const cv::Mat tex = texture(400, 300, 11);
  const cv::Mat a = shifted(tex, 320, 240, 0, 0), b = shifted(tex, 320, 240, 2.5, -1.5);  // b(x) = a(x + (2.5, -1.5))
  TrackingOptions o;
  o.detector = KeypointMethod::Gftt;
  o.max_keypoints = 400;
  std::vector<cv::Point2f> da, db;
  for (const auto& k : detect_keypoints(a, o).keypoints) da.push_back(k.pt);
  for (const auto& k : detect_keypoints(b, o).keypoints) db.push_back(k.pt);
  const KltOptions klt;
  std::vector<cv::DMatch> m;
  const std::vector<cv::Point2f> pa = klt_step(cv::Mat(), {}, a, da, 300, klt, m);
  EXPECT_TRUE(m.empty());
  ASSERT_EQ(pa.size(), 300u);  // the first frame: detected points, spaced, up to max_points
  const std::vector<cv::Point2f> pb = klt_step(a, pa, b, db, 350, klt, m);
  ASSERT_GT(m.size(), 250u);
  int right = 0;
  for (std::size_t i = 0; i < m.size(); ++i) {
    EXPECT_EQ(m[i].trainIdx, static_cast<int>(i));  // tracked points come first, in order
    const cv::Point2f v = pb[m[i].trainIdx] - pa[m[i].queryIdx];
    right += std::hypot(v.x + 2.5, v.y - 1.5) < 0.2;
  }
  EXPECT_GT(right, 0.95 * m.size());
  EXPECT_LE(pb.size(), 350u);
  EXPECT_GT(pb.size(), m.size());  // gaps filled by new corners
  // New points keep the minimum distance from every other point of the frame.
  for (std::size_t i = m.size(); i < pb.size(); ++i)
    for (std::size_t j = 0; j < i; ++j) EXPECT_GE(cv::norm(pb[i] - pb[j]), klt.min_distance_px - 1e-4) << i << " " << j;
  // A blank next image loses every point (nothing to follow) and gains none.
  const std::vector<cv::Point2f> blank = klt_step(b, pb, cv::Mat(240, 320, CV_8UC1, cv::Scalar(100)), {}, 350, klt, m);
  EXPECT_LT(m.size(), pb.size() / 10);
  KltOptions bad;
  bad.window = 3;
  EXPECT_THROW(bad.validate("front_end"), Error);
}

// ---------------------------------------------------------------------------------------------
// The front end on a synthetic stereo video: a fronto-parallel textured wall at Z = 3 m, camera
// sliding 3 cm to the right per frame (fx = 300 px: 3 px per frame; disparity 300 * 0.1 / 3 = 10 px).

namespace {

struct Synthetic {
  fs::path dir;
  Sequence seq;
};

Synthetic make_wall_video(const std::string& name, int frames, std::vector<int> blank_frames = {},
                          bool flat_right = false) {
  Synthetic s;
  // The process id keeps two suites run at once on one machine (a user's and CI's) out of each other's files.
  s.dir = fs::temp_directory_path() / ("smseg_test_frontend_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(s.dir);
  fs::create_directories(s.dir);
  const int W = 320, H = 240;
  const double fx = 300, B = 0.1, Z = 3.0, step = 0.03;
  const double disparity = fx * B / Z, px_per_frame = fx * step / Z;
  const cv::Mat tex = texture(W + 200, H, 21);
  Sequence& q = s.seq;
  q.manifest = s.dir / "sequence.json";
  q.root = s.dir;
  q.name = name;
  q.kind = SequenceKind::Stereo;
  q.size = cv::Size(W, H);
  q.calibration.fx = fx;
  q.calibration.fy = fx;
  q.calibration.cx = W / 2.0;
  q.calibration.cy = H / 2.0;
  q.calibration.baseline = B;
  q.camera_height = 1.2;
  q.label_encoding = LabelEncoding::Index;
  q.classes = {{"wall", 0, {0, 0, 255}}, {"floor", 1, {0, 255, 0}}};
  q.void_class = {"void", 255, {0, 0, 0}};
  for (int f = 0; f < frames; ++f) {
    const bool blank = std::find(blank_frames.begin(), blank_frames.end(), f) != blank_frames.end();
    cv::Mat left = shifted(tex, W, H, f * px_per_frame, 0), right = shifted(tex, W, H, f * px_per_frame + disparity, 0);
    if (blank) left.setTo(100), right.setTo(100);
    if (flat_right) right.setTo(100);
    FrameEntry e;
    e.left = "left_" + std::to_string(f) + ".png";
    e.right = "right_" + std::to_string(f) + ".png";
    cv::imwrite((s.dir / e.left).string(), left);
    cv::imwrite((s.dir / e.right).string(), right);
    if (f == 2) {  // one labelled frame: top half wall, bottom half floor
      cv::Mat lab(H, W, CV_8UC1, cv::Scalar(0));
      lab(cv::Rect(0, H / 2, W, H / 2)).setTo(1);
      e.label = "label_2.png";
      cv::imwrite((s.dir / e.label).string(), lab);
      q.labelled_frames.push_back(f);
    }
    q.frames.push_back(e);
  }
  return s;
}

FrontEndOptions quiet() {
  FrontEndOptions o;
  o.progress = false;
  return o;
}

}  // namespace

TEST(FrontEnd, RecoversTheSlidingCameraAndWritesTheTracksFile) {
  const Synthetic s = make_wall_video("slide", 6);
  const FrontEndResult r = run_stereo_front_end(s.seq, quiet());
  ASSERT_EQ(r.poses.size(), 6u);
  EXPECT_EQ(r.summary.bad_pairs, 0);
  EXPECT_GT(r.summary.valid_points_per_frame_min, 100);
  EXPECT_GT(r.summary.inlier_ratio_mean, 0.8);
  // Camera x is world -X, so sliding right moves the centre along world -X by 3 cm per frame.
  for (int f = 0; f < 6; ++f) {
    EXPECT_NEAR(r.poses[f].t[0], -0.03 * f, 0.005) << "frame " << f;
    EXPECT_NEAR(r.poses[f].t[1], 1.2, 0.005) << "frame " << f;
    EXPECT_NEAR(r.poses[f].t[2], 0, 0.01) << "frame " << f;
  }
  // Observations: depth ~3 m and the stored 3D point is the back-projection of pixel and disparity.
  int labelled = 0;
  for (const auto& tr : r.tracks) {
    ASSERT_GE(tr.size(), 2u);
    for (std::size_t k = 0; k < tr.size(); ++k) {
      EXPECT_NEAR(tr.points[k].z(), 3.0, 0.1);
      const Eigen::Vector3d p = backproject(tr.pixels[k].x, tr.pixels[k].y, tr.disparities[k], 300, 300, 160, 120, 0.1);
      EXPECT_LT((p - tr.points[k]).norm(), 1e-9);
      if (tr.frames[k] == 2) {
        ++labelled;
        EXPECT_EQ(tr.labels[k], tr.pixels[k].y < 119.5 ? 0 : 1);
        EXPECT_EQ(tr.label, tr.labels[k]);
      }
    }
  }
  EXPECT_GT(labelled, 50);
  // Deterministic whatever the thread count: a single-threaded run gives the same tracks and poses.
  const FrontEndResult r2 = [&] {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    return run_stereo_front_end(s.seq, quiet());
  }();
  ASSERT_EQ(r2.tracks.size(), r.tracks.size());
  for (std::size_t i = 0; i < r.tracks.size(); ++i) EXPECT_EQ(r2.tracks[i].frames, r.tracks[i].frames);
  for (int f = 0; f < 6; ++f) EXPECT_EQ(r2.poses[f].t, r.poses[f].t);
  for (std::size_t i = 0; i < r.tracks.size(); ++i) EXPECT_EQ(r2.tracks[i].points, r.tracks[i].points);

  // The tracks file round trip.
  const fs::path file = s.dir / "tracks.json";
  write_tracks(file, r, s.seq.name, s.seq.size, front_end_options_to_json(quiet()));
  const TracksFile back = read_tracks(file, {});
  EXPECT_EQ(back.sequence_name, "slide");
  EXPECT_EQ(back.image_size, cv::Size(320, 240));
  ASSERT_EQ(back.result.tracks.size(), r.tracks.size());
  for (std::size_t i = 0; i < r.tracks.size(); ++i) {
    const auto& a = r.tracks[i];
    const auto& b = back.result.tracks[i];
    ASSERT_EQ(a.frames, b.frames);
    EXPECT_EQ(a.labels, b.labels);
    EXPECT_EQ(a.label, b.label);
    for (std::size_t k = 0; k < a.size(); ++k) {
      EXPECT_NEAR(a.pixels[k].x, b.pixels[k].x, 1e-3);
      EXPECT_NEAR(a.disparities[k], b.disparities[k], 1e-3);
      EXPECT_LT((a.points[k] - b.points[k]).norm(), 1e-4);
    }
  }
  for (int f = 0; f < 6; ++f) EXPECT_EQ(back.result.poses[f].t, r.poses[f].t);
  EXPECT_EQ(back.result.summary.filters.kept_obs, r.summary.filters.kept_obs);
  EXPECT_EQ(back.result.pair_motions.size(), 5u);

  // Bad files: one clear Error naming the file and field.
  Json j = read_json(file);
  j["version"] = 7;
  write_json_atomic(s.dir / "bad_version.json", j);
  EXPECT_THROW(read_tracks(s.dir / "bad_version.json", {}), Error);
  j = read_json(file);
  j["tracks"][0]["x"].erase(0);
  write_json_atomic(s.dir / "bad_x.json", j);
  try {
    read_tracks(s.dir / "bad_x.json", {});
    FAIL() << "a short x array must be an error";
  } catch (const Error& e) {
    EXPECT_NE(e.field().find("tracks[0].x"), std::string::npos) << e.what();
  }
  j = read_json(file);
  j["tracks"][0]["frames"][0] = 99;
  write_json_atomic(s.dir / "bad_frames.json", j);
  EXPECT_THROW(read_tracks(s.dir / "bad_frames.json", {}), Error);
  j = read_json(file);
  j["poses"].erase(1);
  write_json_atomic(s.dir / "bad_poses.json", j);
  EXPECT_THROW(read_tracks(s.dir / "bad_poses.json", {}), Error);
  fs::remove_all(s.dir);
}

TEST(FrontEnd, KltTrackerRecoversTheSlidingCameraWithLongTracks) {
  const Synthetic s = make_wall_video("slide_klt", 8);
  FrontEndOptions o = quiet();
  o.tracker = FrameTracker::Klt;
  o.tracking.detector = KeypointMethod::Gftt;
  const FrontEndResult r = run_stereo_front_end(s.seq, o);
  ASSERT_EQ(r.poses.size(), 8u);
  EXPECT_EQ(r.summary.bad_pairs, 0);
  EXPECT_GT(r.summary.valid_points_per_frame_min, 100);
  EXPECT_GT(r.summary.inlier_ratio_mean, 0.9);
  for (int f = 0; f < 8; ++f) EXPECT_NEAR(r.poses[f].t[0], -0.03 * f, 0.005) << "frame " << f;
  // KLT follows points across the whole video, unlike pairwise matching's short chains.
  EXPECT_GT(r.summary.track_length_mean, 4.0);
  for (const auto& tr : r.tracks)
    for (std::size_t k = 1; k < tr.size(); ++k)
      EXPECT_NEAR(tr.pixels[k].x - tr.pixels[k - 1].x, -3.0 * (tr.frames[k] - tr.frames[k - 1]), 0.3);
  // Deterministic whatever the thread count (the pipeline keeps the frame order).
  const FrontEndResult r1 = [&] {
    tbb::global_control one(tbb::global_control::max_allowed_parallelism, 1);
    return run_stereo_front_end(s.seq, o);
  }();
  ASSERT_EQ(r1.tracks.size(), r.tracks.size());
  for (std::size_t i = 0; i < r.tracks.size(); ++i) EXPECT_EQ(r1.tracks[i].pixels, r.tracks[i].pixels);
  for (int f = 0; f < 8; ++f) EXPECT_EQ(r1.poses[f].t, r.poses[f].t);
  // gftt corners have no descriptors: with the descriptor tracker that is a clear option error.
  o.tracker = FrameTracker::Descriptors;
  EXPECT_THROW(run_stereo_front_end(s.seq, o), Error);
  fs::remove_all(s.dir);
}

TEST(FrontEnd, BridgesABlankFrameAndRecovers) {
  const Synthetic s = make_wall_video("blank", 7, {3});
  const FrontEndResult r = run_stereo_front_end(s.seq, quiet());
  EXPECT_EQ(r.summary.bridged_pairs, (std::vector<int>{2, 3}));
  EXPECT_TRUE(r.pair_motions[2].bridged && r.pair_motions[3].bridged);
  EXPECT_FALSE(r.pair_motions[4].bridged);
  // Constant velocity bridges the gap exactly for this constant motion, and the path goes on.
  for (int f = 0; f < 7; ++f) EXPECT_NEAR(r.poses[f].t[0], -0.03 * f, 0.008) << "frame " << f;
  // Tracks can skip the blank frame only if matched across it, which pairwise matching does not do.
  for (const auto& tr : r.tracks)
    for (int f : tr.frames) EXPECT_NE(f, 3);
  fs::remove_all(s.dir);
}

TEST(FrontEnd, NoValidDisparityIsADocumentedDegradedResult) {
  const Synthetic s = make_wall_video("flat", 4, {}, true);
  const FrontEndResult r = run_stereo_front_end(s.seq, quiet());
  EXPECT_TRUE(r.tracks.empty());
  EXPECT_GT(r.summary.keypoints, 0);
  EXPECT_EQ(r.summary.filters.removed_no_disparity_obs, r.summary.keypoints);
  EXPECT_EQ(r.summary.bad_pairs, 3);
  for (const auto& p : r.poses) EXPECT_EQ(p.t, initial_pose(1.2).t) << "no motion known: the camera stays";
  fs::remove_all(s.dir);
}

TEST(FrontEnd, BadInputIsAClearError) {
  Synthetic s = make_wall_video("bad", 2);
  Sequence no_height = s.seq;
  no_height.camera_height.reset();
  try {
    run_stereo_front_end(no_height, quiet());
    FAIL();
  } catch (const Error& e) {
    EXPECT_EQ(e.field(), "camera_height");
  }
  FrontEndOptions with_height = quiet();
  with_height.camera_height = 1.0;
  EXPECT_NO_THROW(run_stereo_front_end(no_height, with_height));
  Sequence mono = s.seq;
  mono.kind = SequenceKind::Mono;
  EXPECT_THROW(run_stereo_front_end(mono, quiet()), Error);
  Sequence no_baseline = s.seq;
  no_baseline.calibration.baseline.reset();
  EXPECT_THROW(run_stereo_front_end(no_baseline, quiet()), Error);
  fs::remove(s.dir / "right_1.png");
  try {
    run_stereo_front_end(s.seq, quiet());
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("right_1.png"), std::string::npos) << e.what();
  }
  FrontEndOptions bad = quiet();
  bad.tracking.max_keypoints = 0;
  EXPECT_THROW(run_stereo_front_end(s.seq, bad), Error);
  fs::remove_all(s.dir);
}
