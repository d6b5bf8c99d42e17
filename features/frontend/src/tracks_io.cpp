#include "smseg/frontend/tracks_io.hpp"

#include <cmath>
#include <limits>

#include <Eigen/Dense>

namespace smseg::frontend {

namespace {

double rounded(double v, double scale) { return std::round(v * scale) / scale; }

Json rotation_json(const Eigen::Matrix3d& R) {
  Json a = Json::array();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a.push_back(R(i, j));
  return a;
}

std::vector<double> numbers(const JsonView& v, std::size_t expected, const char* what) {
  if (!v.json().is_array()) v.fail(std::string("expected an array of ") + what);
  const std::size_t n = v.size();
  if (expected != static_cast<std::size_t>(-1) && n != expected)
    v.fail("expected " + std::to_string(expected) + " numbers, found " + std::to_string(n));
  std::vector<double> out(n);
  const Json& j = v.json();
  for (std::size_t i = 0; i < n; ++i) {
    if (!j[i].is_number()) v.at(i).fail("expected a number");
    out[i] = j[i].get<double>();
    if (!std::isfinite(out[i])) v.at(i).fail("expected a finite number");
  }
  return out;
}

/// A frame index or a point count: an integer in 0..2^31-1 (checked before it is narrowed to int).
int count(const JsonView& j, const char* key) {
  const std::int64_t v = j.integer(key);
  if (v < 0 || v > std::numeric_limits<int>::max()) j.fail("must be in 0..2147483647", key);
  return static_cast<int>(v);
}

Eigen::Matrix3d rotation_from(const JsonView& v) {
  const auto r = numbers(v, 9, "9 numbers (row-major rotation)");
  Eigen::Matrix3d R;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) R(i, j) = r[3 * i + j];
  if ((R * R.transpose() - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-4 || R.determinant() < 0)
    v.fail("is not a rotation matrix");
  return R;
}

}  // namespace

Json front_end_options_to_json(const FrontEndOptions& o) {
  Json j;
  j["stereo"] = {{"method", stereo_method_name(o.stereo.method)},
                 {"min_disparity", o.stereo.min_disparity},
                 {"num_disparities", o.stereo.num_disparities},
                 {"block_size", o.stereo.block_size},
                 {"texture_threshold", o.stereo.texture_threshold},
                 {"uniqueness_ratio", o.stereo.uniqueness_ratio},
                 {"lr_max_diff", o.stereo.lr_max_diff},
                 {"speckle_window", o.stereo.speckle_window},
                 {"speckle_range", o.stereo.speckle_range},
                 {"prefilter_cap", o.stereo.prefilter_cap}};
  if (o.stereo.sgbm_full_paths) j["stereo"]["sgbm_full_paths"] = true;
  if (o.stereo.lr_check != LeftRightCheck::Mirrored)  // only when not the default: older folders keep their options
    j["stereo"]["lr_check"] = left_right_check_name(o.stereo.lr_check);  // only when on: older folders keep their options
  j["tracking"] = {{"detector", keypoint_method_name(o.tracking.detector)},
                   {"max_keypoints", o.tracking.max_keypoints},
                   {"sift_contrast_threshold", o.tracking.sift_contrast_threshold},
                   {"akaze_threshold", o.tracking.akaze_threshold},
                   {"gftt_quality", o.tracking.gftt_quality},
                   {"max_descriptor_distance", o.tracking.max_descriptor_distance},
                   {"max_pixel_motion", o.tracking.max_pixel_motion}};
  j["tracker"] = frame_tracker_name(o.tracker);
  if (o.tracker == FrameTracker::Klt)
    j["klt"] = {{"window", o.klt.window}, {"max_backward_px", o.klt.max_backward_px}, {"min_distance_px", o.klt.min_distance_px}};
  j["filters"] = {{"min_frames", o.filters.min_frames}, {"require_label", o.filters.require_label}};
  j["motion"] = {{"max_iterations", o.motion.max_iterations},
                 {"confidence", o.motion.confidence},
                 {"inlier_threshold", o.motion.inlier_threshold},
                 {"reference_depth", o.motion.reference_depth},
                 {"depth_exponent", o.motion.depth_exponent},
                 {"min_inliers", o.motion.min_inliers},
                 {"min_inlier_ratio", o.motion.min_inlier_ratio},
                 {"seed", o.motion.seed}};
  j["refine"] = {{"enabled", o.refine.enabled},
                 {"iterations", o.refine.iterations},
                 {"huber_px", o.refine.huber_px},
                 {"inlier_px", o.refine.inlier_px},
                 {"disparity_weight", o.refine.disparity_weight},
                 {"second_hypothesis", o.refine.second_hypothesis},
                 {"second_min_share", o.refine.second_min_share}};
  if (o.gravity.method != GravityMethod::Level)  // only when on: work folders from before keep their options
    j["gravity"] = {{"method", gravity_method_name(o.gravity.method)},
                    {"max_tilt_deg", o.gravity.max_tilt_deg},
                    {"plane_threshold", o.gravity.plane_threshold},
                    {"min_below", o.gravity.min_below},
                    {"min_inliers", o.gravity.min_inliers},
                    {"iterations", o.gravity.iterations},
                    {"seed", o.gravity.seed}};
  if (o.camera_height) j["camera_height"] = *o.camera_height;
  if (o.stereo.method != StereoMethod::Given) j["disparity_offset"] = disparity_offset_name(o.disparity_offset);
  j["first_frame"] = o.first_frame;
  j["last_frame"] = o.last_frame;
  return j;
}

namespace {

Json offset_estimate_json(const OffsetEstimate& e) {
  return {{"kept", e.kept},
          {"best_px", e.best},
          {"extra_px", e.extra},
          {"pairs", e.pairs},
          {"median_error_none_px", e.error_none_px},
          {"median_error_best_px", e.error_best_px}};
}

}  // namespace

std::vector<long> integers(const JsonView& v, std::size_t expected) {
  if (!v.json().is_array()) v.fail("expected an array of integers");
  const std::size_t n = v.size();
  if (n != expected) v.fail("expected " + std::to_string(expected) + " integers, found " + std::to_string(n));
  std::vector<long> out(n);
  const Json& j = v.json();
  for (std::size_t i = 0; i < n; ++i) {
    if (!j[i].is_number_integer()) v.at(i).fail("expected an integer");
    out[i] = j[i].get<long>();
  }
  return out;
}

Json summary_to_json(const FrontEndSummary& s) {
  const FilterCounts& c = s.filters;
  auto share = [](long part, long whole) { return whole > 0 ? static_cast<double>(part) / whole : 0.0; };
  const long after1 = c.observations - c.removed_no_disparity_obs;
  const long after2 = after1 - c.removed_short_obs;
  const long after3 = after2 - (c.unlabelled_removed ? c.unlabelled_obs : 0);
  Json filters = {
      {"observations", c.observations},
      {"tracks", c.tracks},
      {"no_disparity", {{"removed_observations", c.removed_no_disparity_obs},
                        {"removed_tracks", c.removed_no_disparity_tracks},
                        {"share_of_points", share(c.removed_no_disparity_obs, c.observations)}}},
      {"too_short", {{"removed_observations", c.removed_short_obs},
                     {"removed_tracks", c.removed_short_tracks},
                     {"share_of_points", share(c.removed_short_obs, after1)}}},
      {"unlabelled", {{"observations", c.unlabelled_obs},
                      {"tracks", c.unlabelled_tracks},
                      {"removed", c.unlabelled_removed},
                      {"share_of_points", share(c.unlabelled_obs, after2)}}},
      {"inconsistent_labels", {{"removed_observations", c.removed_inconsistent_obs},
                               {"removed_tracks", c.removed_inconsistent_tracks},
                               {"removed", c.inconsistent_removed},
                               {"share_of_points", share(c.removed_inconsistent_obs, after3)}}},
      {"kept_observations", c.kept_obs},
      {"kept_tracks", c.kept_tracks}};
  Json out{{"frames", s.frames},
              {"keypoints", s.keypoints},
              {"filters", filters},
              {"valid_points_per_frame", {{"mean", s.valid_points_per_frame_mean}, {"min", s.valid_points_per_frame_min}}},
              {"track_length", {{"mean", s.track_length_mean}, {"median", s.track_length_median}, {"max", s.track_length_max}}},
              {"motion", {{"inlier_ratio_mean", s.inlier_ratio_mean},
                          {"inlier_ratio_min", s.inlier_ratio_min},
                          {"bad_pairs", s.bad_pairs},
                          {"bridged_pairs", s.bridged_pairs}}},
              {"seconds_per_frame", {{"disparity", s.seconds.disparity},
                                     {"keypoints", s.seconds.keypoints},
                                     {"matching", s.seconds.matching},
                                     {"tracks", s.seconds.tracks},
                                     {"motion", s.seconds.motion}}},
              {"seconds_total_wall", s.seconds.total_wall}};
  if (s.own) out[std::string(s.own->key())] = s.own->to_json();
  // The disparity offset is the stereo front end's (a front end with its own part, the SfM, has none).
  if (!s.own) out["disparity_offset_px"] = s.disparity_offset;
  if (s.offset_estimate) out["disparity_offset_estimate"] = offset_estimate_json(*s.offset_estimate);
  if (s.gravity) {
    const GravityEstimate& g = *s.gravity;
    out["gravity"] = {{"up_before_levelling", {g.up.x(), g.up.y(), g.up.z()}},
                      {"path_up", {g.path_up.x(), g.path_up.y(), g.path_up.z()}},
                      {"source", g.source},
                      {"candidates", g.candidates},
                      {"inliers", g.inliers},
                      {"plane_below_first_camera_m", g.plane_below_first_camera},
                      {"correction_deg", g.correction_deg}};
  }
  return out;
}

namespace {

FilterCounts filter_counts_from_json(const JsonView& f) {
  FilterCounts c;
  c.observations = f.integer("observations");
  c.tracks = f.integer("tracks");
  c.removed_no_disparity_obs = f.at("no_disparity").integer("removed_observations");
  c.removed_no_disparity_tracks = f.at("no_disparity").integer("removed_tracks");
  c.removed_short_obs = f.at("too_short").integer("removed_observations");
  c.removed_short_tracks = f.at("too_short").integer("removed_tracks");
  c.unlabelled_obs = f.at("unlabelled").integer("observations");
  c.unlabelled_tracks = f.at("unlabelled").integer("tracks");
  c.unlabelled_removed = f.at("unlabelled").boolean("removed");
  c.removed_inconsistent_obs = f.at("inconsistent_labels").integer("removed_observations");
  c.removed_inconsistent_tracks = f.at("inconsistent_labels").integer("removed_tracks");
  {
    const JsonView inc = f.at("inconsistent_labels");
    c.inconsistent_removed = inc.has("removed") ? inc.boolean("removed") : true;  // version 1 files before the flag
  }
  c.kept_obs = f.integer("kept_observations");
  c.kept_tracks = f.integer("kept_tracks");
  return c;
}

GravityEstimate gravity_from_json(const JsonView& g) {
  GravityEstimate e;
  const auto vec = [&](const char* key) {
    const auto v = numbers(g.at(key), 3, "3 numbers (a direction)");
    return Eigen::Vector3d(v[0], v[1], v[2]);
  };
  e.up = vec("up_before_levelling");
  e.path_up = vec("path_up");
  e.source = g.str("source");
  e.candidates = static_cast<int>(g.integer("candidates"));
  e.inliers = static_cast<int>(g.integer("inliers"));
  e.plane_below_first_camera = g.num("plane_below_first_camera_m");
  e.correction_deg = g.num("correction_deg");
  return e;
}

}  // namespace

FrontEndSummary summary_from_json(const JsonView& j, const SummaryPartReaders& parts) {
  FrontEndSummary s;
  s.frames = static_cast<int>(j.integer("frames"));
  s.keypoints = j.integer("keypoints");
  s.filters = filter_counts_from_json(j.at("filters"));
  s.valid_points_per_frame_mean = j.at("valid_points_per_frame").num("mean");
  s.valid_points_per_frame_min = static_cast<int>(j.at("valid_points_per_frame").integer("min"));
  s.track_length_mean = j.at("track_length").num("mean");
  s.track_length_median = static_cast<int>(j.at("track_length").integer("median"));
  s.track_length_max = static_cast<int>(j.at("track_length").integer("max"));
  const JsonView m = j.at("motion");
  s.inlier_ratio_mean = m.num("inlier_ratio_mean");
  s.inlier_ratio_min = m.num("inlier_ratio_min");
  s.bad_pairs = static_cast<int>(m.integer("bad_pairs"));
  const JsonView b = m.at("bridged_pairs");
  for (std::size_t i = 0; i < b.size(); ++i) s.bridged_pairs.push_back(static_cast<int>(b.at(i).as_integer()));
  const JsonView t = j.at("seconds_per_frame");
  s.seconds.disparity = t.num("disparity");
  s.seconds.keypoints = t.num("keypoints");
  s.seconds.matching = t.num("matching");
  s.seconds.tracks = t.num("tracks");
  s.seconds.motion = t.num("motion");
  s.seconds.total_wall = j.num("seconds_total_wall");
  for (const auto& [key, read] : parts)
    if (const auto part = j.maybe(key)) s.own = read(*part);
  if (const auto g = j.maybe("gravity")) s.gravity = gravity_from_json(*g);
  if (const auto d = j.maybe("disparity_offset_px")) s.disparity_offset = d->as_num();
  if (const auto e = j.maybe("disparity_offset_estimate"))
    s.offset_estimate = OffsetEstimate{e->num("extra_px"), e->num("best_px"), e->boolean("kept"),
                                       static_cast<int>(e->integer("pairs")), e->num("median_error_none_px"),
                                       e->num("median_error_best_px")};
  return s;
}

void write_tracks(const fs::path& path, const FrontEndResult& r, const std::string& name, cv::Size size,
                  const Json& options) {
  const int n = static_cast<int>(r.poses.size());
  if (r.pair_motions.size() + 1 != r.poses.size() && !(n == 0 && r.pair_motions.empty()))
    throw Error(path.string(), "pair_motions", "need one motion per consecutive pair of poses");
  Json j{{"format", kTracksFormat},
         {"version", kTracksVersion},
         {"sequence", name},
         {"image_size", {size.width, size.height}},
         {"first_frame", r.first_frame},
         {"frame_count", n},
         {"pose_convention",
          r.summary.gravity
              ? "camera-to-world R (row-major) and camera centre t; camera x right, y down, z forward; world Y up "
                "along the estimated gravity (summary.gravity), origin camera_height below the first camera, its "
                "optical axis on the ground along +Z"
              : "camera-to-world R (row-major) and camera centre t; camera x right, y down, z forward; world Y up, "
                "origin on the ground under the first camera, which is assumed level (y axis straight down) and "
                "looking along +Z"},
         {"options", options}};
  Json poses = Json::array();
  for (const auto& p : r.poses) poses.push_back({{"R", p.R}, {"t", p.t}});
  j["poses"] = std::move(poses);
  Json motions = Json::array();
  for (const auto& m : r.pair_motions) {
    motions.push_back({{"R", rotation_json(m.motion.R)},
                       {"t", {m.motion.t.x(), m.motion.t.y(), m.motion.t.z()}},
                       {"points", m.points},
                       {"inliers", m.inliers},
                       {"ok", m.ok},
                       {"bridged", m.bridged},
                       {"rms", m.rms}});
  }
  j["pair_motions"] = std::move(motions);
  Json tracks = Json::array();
  for (const auto& tr : r.tracks) {
    Json x = Json::array(), y = Json::array(), d = Json::array(), P = Json::array();
    for (std::size_t k = 0; k < tr.size(); ++k) {
      x.push_back(rounded(tr.pixels[k].x, 1e3));
      y.push_back(rounded(tr.pixels[k].y, 1e3));
      d.push_back(rounded(tr.disparities[k], 1e3));
      for (int a = 0; a < 3; ++a) P.push_back(rounded(tr.points[k][a], 1e5));
    }
    tracks.push_back({{"frames", tr.frames},
                      {"x", std::move(x)},
                      {"y", std::move(y)},
                      {"d", std::move(d)},
                      {"P", std::move(P)},
                      {"labels", tr.labels},
                      {"label", tr.label}});
  }
  j["tracks"] = std::move(tracks);
  j["summary"] = summary_to_json(r.summary);
  write_file_atomic(path, j.dump() + "\n");
}

namespace {

std::vector<sequence::Pose> poses_from_json(const JsonView& poses, long n) {
  if (static_cast<long>(poses.size()) != n)
    poses.fail("expected frame_count = " + std::to_string(n) + " poses, found " + std::to_string(poses.size()));
  std::vector<sequence::Pose> out;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    const JsonView p = poses.at(i);
    const Eigen::Matrix3d R = rotation_from(p.at("R"));
    const auto t = numbers(p.at("t"), 3, "3 numbers");
    sequence::Pose pose;
    for (int a = 0; a < 3; ++a)
      for (int b = 0; b < 3; ++b) pose.R[3 * a + b] = R(a, b);
    pose.t = {t[0], t[1], t[2]};
    out.push_back(pose);
  }
  return out;
}

std::vector<PairMotion> pair_motions_from_json(const JsonView& motions, long n) {
  const long npairs = std::max(0L, n - 1);
  if (static_cast<long>(motions.size()) != npairs)
    motions.fail("expected " + std::to_string(npairs) + " pair motions, found " + std::to_string(motions.size()));
  std::vector<PairMotion> out;
  for (std::size_t i = 0; i < motions.size(); ++i) {
    const JsonView m = motions.at(i);
    PairMotion pm;
    pm.motion.R = rotation_from(m.at("R"));
    const auto t = numbers(m.at("t"), 3, "3 numbers");
    pm.motion.t = Eigen::Vector3d(t[0], t[1], t[2]);
    pm.points = count(m, "points");
    pm.inliers = count(m, "inliers");
    pm.ok = m.boolean("ok");
    pm.bridged = m.boolean("bridged");
    pm.rms = m.num("rms");
    if (pm.points < 0 || pm.inliers < 0 || pm.inliers > pm.points) m.fail("inconsistent points/inliers counts");
    out.push_back(pm);
  }
  return out;
}

/// One track; its frames must be strictly ascending inside [first_frame, first_frame + n).
Track track_from_json(const JsonView& t, int first_frame, long n) {
  Track tr;
  const JsonView fr = t.at("frames");
  if (!fr.json().is_array() || fr.size() == 0) fr.fail("expected a non-empty array of frame indices");
  const auto frames = integers(fr, fr.size());
  const std::size_t m = frames.size();
  for (std::size_t k = 0; k < m; ++k) {
    if (frames[k] < first_frame || frames[k] >= first_frame + n)
      fr.at(k).fail("frame " + std::to_string(frames[k]) + " is outside the file's frame range");
    if (k > 0 && frames[k] <= frames[k - 1]) fr.at(k).fail("frames must be strictly ascending");
    tr.frames.push_back(static_cast<int>(frames[k]));
  }
  const auto x = numbers(t.at("x"), m, "numbers");
  const auto y = numbers(t.at("y"), m, "numbers");
  const auto d = numbers(t.at("d"), m, "numbers");
  const auto P = numbers(t.at("P"), 3 * m, "numbers");
  const auto labels = integers(t.at("labels"), m);
  for (std::size_t k = 0; k < m; ++k) {
    tr.pixels.emplace_back(static_cast<float>(x[k]), static_cast<float>(y[k]));
    tr.disparities.push_back(static_cast<float>(d[k]));
    tr.points.emplace_back(P[3 * k], P[3 * k + 1], P[3 * k + 2]);
    if (labels[k] < -1 || labels[k] > 254) t.at("labels").at(k).fail("expected -1 or a class position 0..254");
    tr.labels.push_back(static_cast<int>(labels[k]));
  }
  const std::int64_t label = t.integer("label");
  if (label < -1 || label > 254) t.fail("expected -1 or a class position 0..254", "label");
  tr.label = static_cast<int>(label);
  return tr;
}

}  // namespace

TracksFile read_tracks(const fs::path& path, const SummaryPartReaders& parts) {
  const Json doc = read_json(path, kMaxLargeFileBytes);
  const JsonView j(doc, path);
  check_format(j, kTracksFormat, {kTracksVersion});
  TracksFile out;
  out.sequence_name = j.str("sequence");
  const auto size = integers(j.at("image_size"), 2);
  if (size[0] < 1 || size[1] < 1 || size[0] > 20000 || size[1] > 20000)
    j.fail("must be in 1..20000 (as a sequence's)", "image_size");
  out.image_size = cv::Size(static_cast<int>(size[0]), static_cast<int>(size[1]));
  if (auto o = j.maybe("options")) out.options = o->json();
  FrontEndResult& r = out.result;
  r.first_frame = count(j, "first_frame");
  const long n = j.integer("frame_count");
  if (n < 0) j.fail("must be >= 0", "frame_count");
  r.poses = poses_from_json(j.at("poses"), n);
  r.pair_motions = pair_motions_from_json(j.at("pair_motions"), n);
  const JsonView tracks = j.at("tracks");
  if (!tracks.json().is_array()) tracks.fail("expected an array of tracks");
  r.tracks.reserve(tracks.size());
  for (std::size_t i = 0; i < tracks.size(); ++i) r.tracks.push_back(track_from_json(tracks.at(i), r.first_frame, n));
  r.summary = summary_from_json(j.at("summary"), parts);
  return out;
}

void check_made_from(const TracksFile& tracks, const fs::path& path, const sequence::Sequence& seq) {
  const auto size_text = [](cv::Size s) { return std::to_string(s.width) + "x" + std::to_string(s.height); };
  if (tracks.sequence_name != seq.name)
    throw Error(path.string(), "sequence",
                "is for sequence \"" + tracks.sequence_name + "\", not \"" + seq.name + "\" (" +
                    seq.manifest.string() + "): a work folder of another sequence");
  if (tracks.image_size != seq.size)
    throw Error(path.string(), "image_size",
                "is " + size_text(tracks.image_size) + ", the sequence's images are " + size_text(seq.size) + " (" +
                    seq.manifest.string() + ")");
  const long last = tracks.result.first_frame + static_cast<long>(tracks.result.poses.size());
  if (last > seq.frame_count())
    throw Error(path.string(), "frame_count",
                "poses frames up to " + std::to_string(last - 1) + ", the sequence has " +
                    std::to_string(seq.frame_count()) + " frames (" + seq.manifest.string() + ")");
}

}  // namespace smseg::frontend
