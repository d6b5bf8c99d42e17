#include "smseg/stacks/extract.hpp"

#include <atomic>
#include <chrono>
#include <cstdio>

#include <Eigen/LU>
#include <opencv2/imgproc.hpp>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for_each.h>

#include "smseg/sfm/sfm.hpp"
#include "smseg/frontend/tracks_io.hpp"
#include "smseg/stacks/appearance.hpp"
#include "smseg/stacks/dense.hpp"
#include "smseg/stacks/plane_sweep.hpp"
#include "smseg/common/digest.hpp"
#include "smseg/common/options.hpp"
#include "smseg/common/output.hpp"
#include "smseg/common/progress.hpp"

namespace smseg::stacks {

namespace {

double seconds_since(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

// The feature options as run: HeightReference::Auto as the front end measures heights.
FeatureOptions effective_features(const FrontEnd& front_end, const ExtractOptions& o) {
  FeatureOptions f = o.features;
  if (f.height_reference == HeightReference::Auto) f.height_reference = front_end.auto_height_reference();
  return f;
}

// FNV-1a (64 bits) of the sequence's manifest: its frames, calibration and classes, what the stacks are
// made of besides the options. Recorded in stacks.json so that a resume reuses only stacks of this input.
std::string sequence_digest(const sequence::Sequence& seq) {
  std::error_code ec;
  if (seq.manifest.empty() || !fs::is_regular_file(seq.manifest, ec)) return "none";  // made in memory
  return fnv1a64_hex(read_file(seq.manifest));
}

Json options_json(const sequence::Sequence& seq, const FrontEnd& front_end, const ExtractOptions& o) {
  Json fe = front_end.options_json(o);
  if (!fe.contains("camera_height") && seq.camera_height) fe["camera_height"] = *seq.camera_height;
  return {{"front_end", fe},
          {"features", feature_options_json(effective_features(front_end, o))},
          {"input", {{"sequence_json_fnv1a64", sequence_digest(seq)}}}};
}

// The channels of a stack, in stacks.json's order: the six, appearance, dense geometry.
std::vector<std::string> stack_channel_names(const FeatureOptions& o) {
  std::vector<std::string> names = structure_feature_names();
  if (o.appearance) names.insert(names.end(), appearance_feature_names().begin(), appearance_feature_names().end());
  if (o.dense) names.insert(names.end(), dense_feature_names().begin(), dense_feature_names().end());
  return names;
}

// Whether an earlier run's stacks.json describes stacks made the way this run makes them. Work folders
// from before the input digest was recorded are judged without it. The channel list counts too: the
// same options made five dense channels before fZC.
bool same_stacks(const StackManifest& old, const sequence::Sequence& seq, const Json& options,
                 const std::vector<std::string>& channels) {
  Json old_options = old.options, new_options = options;
  if (!old_options.contains("input")) new_options.erase("input");
  if (old_options != new_options || old.size != seq.size || old.features != channels) return false;
  if (old.version != kStacksVersion || old.base) return false;  // an older layout: rebuilt (--force)
  // An old manifest may name a folder that can no longer be resolved (too long, a loop of links):
  // then it is not this sequence.
  std::error_code ec_old, ec_new;
  const fs::path old_root = fs::weakly_canonical(old.sequence, ec_old);
  const fs::path new_root = fs::weakly_canonical(seq.root, ec_new);
  return !ec_old && !ec_new && old_root == new_root;
}

// Stack files of another making (other options or sequence, or no stacks.json to say) must not be taken
// for this run's by a resume: they go before the new stacks.json is written. The old stacks.json goes
// first, so that a kill in between leaves stacks that no manifest vouches for (removed by the next run).
void remove_foreign_stacks(const fs::path& work) {
  std::error_code ec;
  fs::remove(work / "stacks.json", ec);
  if (ec) throw Error((work / "stacks.json").string(), "", "cannot be removed: " + ec.message());
  fs::remove_all(work / "stacks", ec);
  if (ec) throw Error((work / "stacks").string(), "", "cannot remove the stacks of other options: " + ec.message());
}

// Whether the frame's values file is on disk. It is written whole (temporary, then rename), so a file
// that is there is complete.
bool frame_files_present(const fs::path& work, int f) {
  std::error_code ec;
  return fs::exists(values_path(work, f), ec);
}

// False colour over the raster's range. A sparse feature is shown only where there are points (`points`,
// the dilated fD raster, non-empty), enlarged to 3x3 so that they are visible at a glance.
cv::Mat false_colour(const cv::Mat& raster, const cv::Mat& points) {
  cv::Mat src = raster;
  cv::Mat mask;
  if (!points.empty()) {
    cv::dilate(raster, src, cv::Mat(), cv::Point(-1, -1), 1);
    cv::Mat lo_src;
    cv::erode(raster, lo_src, cv::Mat(), cv::Point(-1, -1), 1);
    src = cv::max(src, 0.0) + cv::min(lo_src, 0.0);  // keep negative values (below the ground) visible
    mask = points > 0;
  }
  double lo, hi;
  cv::minMaxLoc(src, &lo, &hi, nullptr, nullptr, mask);
  cv::Mat u8;
  src.convertTo(u8, CV_8U, hi > lo ? 255.0 / (hi - lo) : 0.0, hi > lo ? -255.0 * lo / (hi - lo) : 128.0);
  cv::Mat out;
  cv::applyColorMap(u8, out, cv::COLORMAP_VIRIDIS);
  if (!mask.empty()) out.setTo(cv::Scalar::all(0), ~mask);
  return out;
}

// The ground-truth path moved rigidly so that its pose at `first` coincides with `estimated_first`.
std::vector<sequence::Pose> align_at_first_frame(const std::vector<sequence::Pose>& gt, int first, const sequence::Pose& estimated_first) {
  const auto mat = [](const sequence::Pose& p) {
    Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) m(r, c) = p.R[r * 3 + c];
      m(r, 3) = p.t[r];
    }
    return m;
  };
  const Eigen::Matrix4d A = mat(estimated_first) * mat(gt[first]).inverse();
  std::vector<sequence::Pose> out;
  for (std::size_t i = first; i < gt.size(); ++i) {
    const Eigen::Matrix4d m = A * mat(gt[i]);
    sequence::Pose p;
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) p.R[r * 3 + c] = m(r, c);
      p.t[r] = m(r, 3);
    }
    out.push_back(p);
  }
  return out;
}

}  // namespace

Json feature_options_json(const FeatureOptions& o) {
  Json j = feature_options_table().to_json(o, options::kFile);
  if (o.causal) j["causal_tracks"] = "from-min-frames";  // stacks made before the causal track rule differ
  return j;
}

PointCloudVideo video_from_tracks(const frontend::FrontEndResult& fe, int frame_count, int causal_min_frames) {
  PointCloudVideo v;
  v.poses.assign(frame_count, sequence::Pose{});
  v.observations.resize(frame_count);
  for (std::size_t i = 0; i < fe.poses.size(); ++i) {
    const int f = fe.first_frame + static_cast<int>(i);
    if (f >= 0 && f < frame_count) v.poses[f] = fe.poses[i];
  }
  for (std::size_t k = 0; k < fe.tracks.size(); ++k) {
    const frontend::Track& t = fe.tracks[k];
    for (std::size_t i = causal_min_frames > 0 ? causal_min_frames - 1 : 0; i < t.size(); ++i) {
      const int f = t.frames[i];
      if (f < 0 || f >= frame_count) continue;
      Observation o;
      o.track = static_cast<int>(k);
      o.x = t.pixels[i].x;
      o.y = t.pixels[i].y;
      o.cam = t.points[i];
      v.observations[f].push_back(o);
    }
  }
  return v;
}

namespace {

// What a plane sweep of a monocular run needs beyond the images: which frames have an SfM pose, and
// its camera (the focal it used; the principal point as it took it). Bridged frames count: their
// rotation and direction of travel are the essential matrix's, only the step length is guessed, and
// where the guess is wrong the two neighbours disagree and the consistency check drops the pixel. On
// CamVid's 1 Hz train runs (24-47 % bridged) that raises the valid share from 10-15 % to 13-19 % and
// the val figures by +0.5 global, +0.8 class average (docs/sfm.md).
struct SweepInputs {
  std::vector<bool> usable;
  sequence::Calibration calibration;
};

SweepInputs sweep_inputs(const sequence::Sequence& seq, const frontend::FrontEndResult& fe) {
  SweepInputs in;
  in.usable.assign(seq.frame_count(), false);
  for (int k = 0; k < static_cast<int>(fe.poses.size()); ++k) {
    const int f = fe.first_frame + k;
    if (f >= 0 && f < seq.frame_count()) in.usable[f] = true;
  }
  const sfm::SfmSummary* made = sfm::sfm_summary_of(fe.summary);
  const double focal = made ? made->focal : 0;
  if (!(focal > 0)) throw Error(seq.manifest.string(), "focal", "the structure from motion reported no focal length");
  in.calibration = sfm::sfm_camera(seq, focal);
  return in;
}

}  // namespace

cv::Mat feature_preview(const std::vector<cv::Mat>& rasters, const std::vector<std::string>& names) {
  CV_Assert(!rasters.empty() && rasters.size() == names.size());
  const int cols = 3, rows = (static_cast<int>(rasters.size()) + cols - 1) / cols;
  const int W = rasters[0].cols, H = rasters[0].rows, gap = 4;
  cv::Mat out(rows * (H + gap) - gap, cols * (W + gap) - gap, CV_8UC3, cv::Scalar::all(255));
  cv::Mat points;
  const auto fd = std::find(names.begin(), names.end(), "fD");
  if (fd != names.end()) cv::dilate(rasters[fd - names.begin()], points, cv::Mat(), cv::Point(-1, -1), 1);
  for (std::size_t k = 0; k < rasters.size(); ++k) {
    // The point features hold values at the tracked points only; fOx, fOy and the image and dense
    // channels cover the frame.
    const bool sparse = names[k] == "fH" || names[k] == "fC" || names[k] == "fD" || names[k] == "fR";
    cv::Mat tile = false_colour(rasters[k], sparse ? points : cv::Mat());
    cv::putText(tile, names[k], cv::Point(6, 18), cv::FONT_HERSHEY_SIMPLEX, 0.55, cv::Scalar::all(255), 2);
    const int r = static_cast<int>(k) / cols, c = static_cast<int>(k) % cols;
    tile.copyTo(out(cv::Rect(c * (W + gap), r * (H + gap), W, H)));
  }
  return out;
}

namespace {

// Frames and previews asked for must lie in the sequence (Error naming the option).
void check_frame_options(const sequence::Sequence& seq, const ExtractOptions& opt) {
  if (opt.frames.begin >= seq.frame_count())
    throw Error("", "--frames", opt.frames.str() + " selects none of the " + std::to_string(seq.frame_count()) +
                                   " frames of " + seq.manifest.string());
  for (int f : opt.preview)
    if (f < 0 || f >= seq.frame_count())
      throw Error("", "--preview", "frame " + std::to_string(f) + " is outside the sequence (0.." +
                                       std::to_string(seq.frame_count() - 1) + ")");
}

// The work folder's stacks.json for this run, written before anything else so that an interrupted run
// can resume. A work folder made with other options is rebuilt only when asked. resume_from_files: with
// the same options and input, every frame whose files are on disk is kept, whether an earlier run
// finished (listed in stacks.json) or was killed (stacks.json is written first, so the files on disk
// were made under it).
StackManifest start_manifest(const sequence::Sequence& seq, const fs::path& work, const Json& options,
                             const ExtractOptions& opt, bool& resume_from_files) {
  StackManifest m;
  std::error_code ec;
  remove_stale_temporaries(work);  // what runs killed between write and rename left
  remove_stale_temporaries(work / "stacks");
  remove_stale_temporaries(work / "preview");
  resume_from_files = false;
  const std::vector<std::string> channels = stack_channel_names(opt.features);
  if (fs::exists(work / "stacks.json", ec)) {
    StackManifest old = load_stack_manifest(work);
    const bool same = same_stacks(old, seq, options, channels);
    if (!same && !opt.force)
      throw Error((work / "stacks.json").string(), "options",
                  "this work folder was made from another sequence, with other options or with other channels (an older "
                  "extract-features); use --force to rebuild it");
    if (same && !opt.force) m = old;
    resume_from_files = same && old.options == options;
    if (!same) remove_foreign_stacks(work);
  } else {
    remove_foreign_stacks(work);
  }
  m.work = work;
  m.sequence = fs::absolute(seq.root);
  m.sequence_name = seq.name;
  m.size = seq.size;
  m.features = channels;
  m.classes.clear();
  for (const auto& c : seq.classes) m.classes.push_back(c.name);
  m.options = options;
  if (opt.force) {
    m.frames.clear();
    m.labelled_frames.clear();
  }
  save_stack_manifest(m);
  return m;
}

// The front end over the whole sequence (fC needs the future path), timed into the report; its tracks
// written to WORK/tracks.json. Error when it kept no tracked point.
frontend::FrontEndResult run_front_end(const sequence::Sequence& seq, const fs::path& work, const FrontEnd& front_end,
                             const ExtractOptions& opt, const Json& options, ExtractReport& report) {
  const auto t0 = std::chrono::steady_clock::now();
  frontend::FrontEndResult fe = front_end.run(seq, opt);
  report.front_end_seconds = seconds_since(t0);
  report.summary = fe.summary;
  if (fe.tracks.empty())
    throw Error(seq.manifest.string(), "",
                std::string("the front end kept no tracked 3D point in any of the ") + std::to_string(seq.frame_count()) +
                    " frames (" + std::string(front_end.no_tracks_hint()) +
                    "): there is nothing to compute features from");
  frontend::write_tracks(work / "tracks.json", fe, seq.name, seq.size, options["front_end"]);
  return fe;
}

// WORK/path.png: the camera path from above, with the ground truth's when the sequence has one.
void write_path_picture(const sequence::Sequence& seq, const fs::path& work, const frontend::FrontEndResult& fe,
                        const std::vector<CloudPoint>& cloud) {
  std::vector<sequence::Pose> gt;
  if (static_cast<int>(seq.gt_poses.size()) == seq.frame_count() && !fe.poses.empty())
    gt = align_at_first_frame(seq.gt_poses, fe.first_frame, fe.poses.front());
  sequence::write_image_atomic(work / "path.png", plot_top_down(fe.poses, gt.empty() ? nullptr : &gt, cloud, seq));
}

// The frames of --frames to write now (todo) and those whose stacks are on disk already (kept).
void plan_frames(const sequence::Sequence& seq, const fs::path& work, const ExtractOptions& opt, const StackManifest& m,
                 bool resume_from_files, std::vector<int>& todo, std::vector<int>& kept) {
  for (int f = 0; f < seq.frame_count(); ++f) {
    if (!opt.frames.contains(f)) continue;
    const bool done = (m.has_frame(f) || resume_from_files) && frame_files_present(work, f);
    if (done && !opt.force) {
      kept.push_back(f);
      continue;
    }
    todo.push_back(f);
  }
}

// The channels after the six, in stacks.json's order: appearance, then dense geometry (stereo
// matching, or a plane sweep over the SfM's posed neighbours).
// The sequence as the dense matcher reads it: with the disparity offset the stereo front end added
// (its self-calibrated one with --disparity-offset auto, or the one given), not only the calibration's.
sequence::Sequence with_front_end_offset(const sequence::Sequence& seq, const frontend::FrontEndResult& fe,
                                         const ExtractOptions& opt, bool monocular) {
  sequence::Sequence s = seq;
  if (!monocular && opt.front_end.disparity_offset.mode != frontend::DisparityOffsetChoice::Mode::Calibration)
    s.calibration.disparity_offset = fe.summary.disparity_offset;
  return s;
}

class ImageRasters {
 public:
  ImageRasters(const sequence::Sequence& seq, const frontend::FrontEndResult& fe, const PointCloudVideo& video,
               std::optional<double> camera_height, const ExtractOptions& opt, bool monocular)
      : seq_(seq), dense_seq_(with_front_end_offset(seq, fe, opt, monocular)), video_(video),
        camera_height_(camera_height), opt_(opt), monocular_(monocular),
        dense_stereo_(dense_stereo_options(opt.front_end.stereo)),
        sweep_(monocular && opt.features.dense ? sweep_inputs(seq, fe) : SweepInputs{}) {}

  void append(int f, std::vector<cv::Mat>& rasters) const {
    if (opt_.features.appearance) append_appearance_rasters(seq_.load_left(f), rasters);
    if (opt_.features.dense)
      append_dense_rasters(depth(f), monocular_ ? sweep_.calibration : seq_.calibration, video_.poses[f], rasters,
                           height_shift(camera_height_, video_.poses[f]),
                           camera_path_near(video_.poses, f, opt_.features.future_frames, opt_.features.causal));
  }

 private:
  cv::Mat depth(int f) const {
    if (!monocular_) return dense_depth(dense_seq_, f, dense_stereo_);
    std::vector<SweepView> views;
    const SweepNeighbourOptions choice{opt_.features.sweep_reach, opt_.features.sweep_baseline};
    for (int g : sweep_neighbours(f, sweep_.usable, video_.poses, choice))
      views.push_back({seq_.load_left_gray(g), video_.poses[g]});
    PlaneSweepOptions sweep;
    sweep.scale = opt_.features.sweep_scale;
    return plane_sweep_depth(seq_.load_left_gray(f), video_.poses[f], views, sweep_.calibration, sweep);
  }

  const sequence::Sequence& seq_;
  const sequence::Sequence dense_seq_;
  const PointCloudVideo& video_;
  std::optional<double> camera_height_;
  const ExtractOptions& opt_;
  bool monocular_;
  frontend::StereoOptions dense_stereo_;
  SweepInputs sweep_;
};

// Writes the stacks of `todo` in parallel; returns the seconds spent computing features, summed.
double write_stacks(const sequence::Sequence& seq, const fs::path& work, const std::vector<int>& todo,
                    const PointCloudVideo& video, const PointAttributes& attrs, const ImageRasters& image_rasters,
                    const std::vector<std::string>& channels, bool progress_on) {
  Progress progress("extract-features", static_cast<long>(todo.size()), progress_on);
  struct Buffers {
    std::vector<cv::Mat> rasters;
  };
  tbb::enumerable_thread_specific<Buffers> buffers;
  std::atomic<double> feature_seconds{0};
  tbb::parallel_for_each(todo.begin(), todo.end(), [&](int f) {
    Buffers& b = buffers.local();
    const auto tf = std::chrono::steady_clock::now();
    rasterise_features(video, attrs, f, seq.size, b.rasters);
    image_rasters.append(f, b.rasters);
    double s = feature_seconds.load();
    const double dt = seconds_since(tf);
    while (!feature_seconds.compare_exchange_weak(s, s + dt)) {
    }
    const cv::Mat gray = seq.load_left_gray(f);
    const cv::Mat labels = seq.is_labelled(f) ? seq.load_labels(f) : cv::Mat();
    const bool appearance = std::any_of(channels.begin(), channels.end(), is_appearance_feature);
    write_frame_values(work, f, seq.size, b.rasters, gray, labels, channels, appearance ? seq.load_left(f) : cv::Mat());
    progress.tick();
  });
  progress.finish();
  return feature_seconds.load();
}

// The mean size of the frames' values files.
std::size_t mean_frame_bytes(const StackManifest& m) {
  std::uintmax_t total = 0;
  std::error_code ec;
  for (int f : m.frames) {
    const auto n = fs::file_size(values_path(m.work, f), ec);
    total += ec ? 0 : n;
  }
  return m.frames.empty() ? 0 : static_cast<std::size_t>(total / m.frames.size());
}

// Previews of the frames asked for, whether their stacks were written now or earlier.
void write_previews(const sequence::Sequence& seq, const fs::path& work, const std::vector<int>& frames,
                    const PointCloudVideo& video, const PointAttributes& attrs, const ImageRasters& image_rasters,
                    const std::vector<std::string>& channels) {
  for (int f : frames) {
    char name[32];
    std::snprintf(name, sizeof name, "%06d_features.png", f);
    std::vector<cv::Mat> rasters = rasterise_features(video, attrs, f, seq.size);
    image_rasters.append(f, rasters);
    sequence::write_image_atomic(work / "preview" / name, feature_preview(rasters, channels));
  }
}

// Records the frames now on disk (all of them, including earlier runs', finished or killed).
void record_frames(const sequence::Sequence& seq, StackManifest& m, const std::vector<int>& todo, const std::vector<int>& kept) {
  std::vector<int> frames = m.frames;
  frames.insert(frames.end(), todo.begin(), todo.end());
  frames.insert(frames.end(), kept.begin(), kept.end());
  std::sort(frames.begin(), frames.end());
  frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
  m.frames = frames;
  m.labelled_frames.clear();
  for (int f : frames)
    if (seq.is_labelled(f)) m.labelled_frames.push_back(f);
  save_stack_manifest(m);
}

}  // namespace

std::string report_text(const ExtractReport& r, const std::string& work) {
  const auto& s = r.summary;
  char line[512];
  std::snprintf(line, sizeof line,
                "%s: %d frames written, %d already done; front end %.1f s (%.1f ms/frame), features %.2f ms/frame;\n"
                "valid points per frame: mean %.0f, min %d; tracks kept %ld of %ld; mean track length %.1f; "
                "motion inlier ratio %.2f; bridged pairs %zu; %.1f MB per frame on disk",
                work.c_str(), r.frames_written, r.frames_skipped, r.front_end_seconds,
                1000 * r.front_end_seconds / std::max(1, s.frames), 1000 * r.features_seconds_per_frame,
                s.valid_points_per_frame_mean, s.valid_points_per_frame_min, s.filters.kept_tracks, s.filters.tracks,
                s.track_length_mean, s.inlier_ratio_mean, s.bridged_pairs.size(), r.bytes_per_frame / 1e6);
  std::string text = std::string(line) + "\n";
  const sfm::SfmSummary* sfm_part = sfm::sfm_summary_of(s);
  if (!sfm_part) return text;
  const sfm::SfmSummary& m = *sfm_part;
  std::snprintf(line, sizeof line,
                "sfm (%s): focal %.1f px (%s); key frames %d; frames posed %d, still %d, bridged %d of %d; "
                "reprojection RMS %.3f px over %ld observations; scale %.4g m/unit (ground inliers %d); "
                "%.1f ms/frame SfM of which %.1f BA",
                m.tracker.c_str(), m.focal, m.focal_source.c_str(), m.keyframes, m.posed_frames, m.still_frames,
                m.bridged_frames, s.frames, m.reprojection_rms_px, m.observations, m.scale, m.ground_inliers,
                1000 * m.seconds_sfm, 1000 * m.seconds_ba);
  return text + line + "\n";
}

ExtractReport extract_features(const sequence::Sequence& seq, const fs::path& work, const ExtractOptions& opt) {
  opt.features.validate();
  const FrontEnd& front_end = front_end_for(seq, opt);
  front_end.check(seq, opt);
  const bool monocular = front_end.monocular();  // dense depth from a plane sweep over posed neighbours
  check_frame_options(seq, opt);
  ExtractReport report;
  const Json options = options_json(seq, front_end, opt);
  bool resume_from_files = false;
  StackManifest m = start_manifest(seq, work, options, opt, resume_from_files);

  const frontend::FrontEndResult fe = run_front_end(seq, work, front_end, opt, options, report);
  const int min_frames = front_end.min_track_frames(opt);
  const PointCloudVideo video = video_from_tracks(fe, seq.frame_count(), opt.features.causal ? min_frames : 0);
  const FeatureOptions features = effective_features(front_end, opt);
  const PointAttributes attrs = compute_point_attributes(video, features);
  const std::optional<double> camera_height = reference_camera_height(features, video.poses);
  report.cloud = track_cloud(fe, video, attrs);
  write_path_picture(seq, work, fe, report.cloud);

  std::vector<int> todo, kept;
  plan_frames(seq, work, opt, m, resume_from_files, todo, kept);
  report.frames_skipped = static_cast<int>(kept.size());
  const ImageRasters image_rasters(seq, fe, video, camera_height, opt, monocular);
  const double feature_seconds = write_stacks(seq, work, todo, video, attrs, image_rasters, m.features, opt.progress);
  write_previews(seq, work, opt.preview, video, attrs, image_rasters, m.features);
  report.frames_written = static_cast<int>(todo.size());
  report.features_seconds_per_frame = todo.empty() ? 0.0 : feature_seconds / double(todo.size());
  record_frames(seq, m, todo, kept);
  report.bytes_per_frame = mean_frame_bytes(m);
  return report;
}

}  // namespace smseg::stacks
