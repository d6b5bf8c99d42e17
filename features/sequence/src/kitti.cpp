#include "smseg/sequence/kitti.hpp"

#include <algorithm>
#include <cmath>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "smseg/sequence/camvid.hpp"
#include "smseg/sequence/image_file.hpp"
#include "sequence_parse.hpp"

namespace smseg::sequence {

namespace {

/// The lines of a text file that hold something, each split into its whitespace-separated words, with
/// their line numbers (for errors).
struct NumberedLine {
  int number = 0;
  std::vector<std::string> words;
};

std::vector<NumberedLine> read_word_lines(const fs::path& file) {
  const std::string text = read_file(file);
  std::vector<NumberedLine> lines;
  // Lines are cut from the text where it lies (a copy of a 256 MiB file would double what it takes).
  int number = 0;
  for (std::size_t begin = 0; begin < text.size();) {
    const std::size_t newline = text.find('\n', begin);
    const std::size_t end = newline == std::string::npos ? text.size() : newline;
    NumberedLine line{++number, {}};
    std::istringstream words(text.substr(begin, end - begin));
    begin = end + 1;
    for (std::string w; words >> w;) line.words.push_back(w);
    if (!line.words.empty()) lines.push_back(std::move(line));
  }
  return lines;
}

/// `count` finite numbers from the line's words (after an optional "P0:"-style label).
std::vector<double> parse_numbers(const fs::path& file, const NumberedLine& line, std::size_t count) {
  std::size_t first = !line.words.empty() && line.words[0].back() == ':' ? 1 : 0;
  const std::string where = "line " + std::to_string(line.number);
  if (line.words.size() - first != count)
    throw Error(file.string(), where,
                "expected " + std::to_string(count) + " numbers, found " + std::to_string(line.words.size() - first));
  std::vector<double> v;
  for (std::size_t k = first; k < line.words.size(); ++k) {
    const std::string& w = line.words[k];
    std::size_t used = 0;
    double x = 0;
    try {
      x = std::stod(w, &used);
    } catch (const std::exception&) {
      used = 0;
    }
    if (used != w.size() || !std::isfinite(x)) throw Error(file.string(), where, "\"" + w + "\" is not a finite number");
    v.push_back(x);
  }
  return v;
}

/// The left and right image folders of either layout.
std::pair<fs::path, fs::path> image_folders(const fs::path& root) {
  for (const auto& [l, r] : {std::pair<const char*, const char*>{"image_0", "image_1"}, {"image_l", "image_r"}}) {
    std::error_code ec;
    if (fs::is_directory(root / l, ec) && fs::is_directory(root / r, ec)) return {root / l, root / r};
  }
  throw Error(root.string(), "", "no stereo image folders (image_0 and image_1, or image_l and image_r)");
}

std::vector<std::string> png_names(const fs::path& folder) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder))
    if (entry.is_regular_file() && entry.path().extension() == ".png") names.push_back(entry.path().filename().string());
  std::sort(names.begin(), names.end());
  if (names.empty()) throw Error(folder.string(), "", "no PNG images");
  return names;
}

cv::Size image_size(const fs::path& file) {
  return read_image_file(file, cv::IMREAD_UNCHANGED).size();
}

/// Seconds of each frame since the first: from times.txt when there is one, else frame / fps.
std::vector<double> frame_times(const fs::path& root, std::size_t frames, double fps) {
  std::vector<double> times(frames);
  const fs::path file = root / "times.txt";
  std::error_code ec;
  if (!fs::exists(file, ec)) {
    for (std::size_t i = 0; i < frames; ++i) times[i] = static_cast<double>(i) / fps;
    return times;
  }
  const auto lines = read_word_lines(file);
  if (lines.size() != frames)
    throw Error(file.string(), "", std::to_string(lines.size()) + " times for " + std::to_string(frames) + " frames");
  for (std::size_t i = 0; i < frames; ++i) {
    times[i] = parse_numbers(file, lines[i], 1)[0];
    if (i > 0 && !(times[i] > times[i - 1]))
      throw Error(file.string(), "line " + std::to_string(lines[i].number), "times must increase");
  }
  const double t0 = times[0];
  for (double& t : times) t -= t0;
  return times;
}

}  // namespace

void KittiImportOptions::validate() const {
  if (!(camera_height > 0)) throw Error("", "--camera-height", "must be positive (metres)");
  if (!(fps > 0)) throw Error("", "--fps", "must be positive");
  if (disparity_offset && !(std::abs(*disparity_offset) <= 1000))
    throw Error("", "--disparity-offset", "must be a number of pixels in -1000..1000");
}

KittiCalibration read_kitti_calibration(const fs::path& file) {
  const auto lines = read_word_lines(file);
  if (lines.size() < 2) throw Error(file.string(), "", "expected the projection matrices P0 and P1 (two lines of 12 numbers)");
  const std::vector<double> p0 = parse_numbers(file, lines[0], 12), p1 = parse_numbers(file, lines[1], 12);
  KittiCalibration c;
  c.fx = p0[0];
  c.cx = p0[2];
  c.fy = p0[5];
  c.cy = p0[6];
  if (!(c.fx > 0) || !(c.fy > 0)) throw Error(file.string(), "line " + std::to_string(lines[0].number), "focal length must be positive");
  if (!(p1[0] > 0)) throw Error(file.string(), "line " + std::to_string(lines[1].number), "focal length must be positive");
  c.baseline = -p1[3] / p1[0];
  c.cx_right = p1[2];
  if (!(c.baseline > 0))
    throw Error(file.string(), "line " + std::to_string(lines[1].number),
                "P1 gives no positive baseline (-P1[0][3] / fx): is it the right camera of the left one?");
  return c;
}

std::vector<Pose> read_kitti_poses(const fs::path& file, double camera_height) {
  // KITTI: X_cam0 = R_k X_camk + t_k, axes x right, y down, z forward. Ours: world Y up, so turn the
  // first camera's frame half a turn about its z axis (x -> -x, y -> -y) and lift it camera_height above
  // the ground: X_world = F (R_k X_camk + t_k) + (0, h, 0), F = diag(-1, -1, 1).
  std::vector<Pose> poses;
  for (const auto& line : read_word_lines(file)) {
    const std::vector<double> m = parse_numbers(file, line, 12);
    Pose p;
    for (int r = 0; r < 3; ++r) {
      const double flip = r < 2 ? -1.0 : 1.0;
      for (int k = 0; k < 3; ++k) p.R[3 * r + k] = flip * m[4 * r + k];
      p.t[r] = flip * m[4 * r + 3];
    }
    p.t[1] += camera_height;
    if (!is_rotation(p.R))
      throw Error(file.string(), "line " + std::to_string(line.number),
                  "its first three columns are not a rotation matrix (R R^T = I, det R = 1)");
    poses.push_back(p);
  }
  if (poses.empty()) throw Error(file.string(), "", "no poses");
  return poses;
}

std::vector<ClassInfo> camvid_road_classes(ClassInfo* void_class) {
  // CamVid's 11-class palette (Brostow et al. 2008), as in its classes.csv.
  std::vector<ClassInfo> classes = {
      {"Sky", 0, {128, 128, 128}},      {"Building", 1, {128, 0, 0}},   {"Pole", 2, {192, 192, 128}},
      {"Road", 3, {128, 64, 128}},      {"Pavement", 4, {60, 40, 222}}, {"Tree", 5, {128, 128, 0}},
      {"SignSymbol", 6, {192, 128, 128}}, {"Fence", 7, {64, 64, 128}}, {"Car", 8, {64, 0, 128}},
      {"Pedestrian", 9, {64, 64, 0}},   {"Bicyclist", 10, {0, 128, 192}}};
  if (void_class) *void_class = {"Void", 11, {0, 0, 0}};
  return classes;
}

Sequence import_kitti(const fs::path& dir, const fs::path& out, const KittiImportOptions& opt) {
  opt.validate();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw Error(dir.string(), "", "no such folder");
  const fs::path root = fs::canonical(dir);
  const auto [left_dir, right_dir] = image_folders(root);
  const std::vector<std::string> names = png_names(left_dir);
  for (const auto& n : names)
    if (!fs::is_regular_file(right_dir / n, ec)) throw Error((right_dir / n).string(), "", "the right image of " + n + " is missing");

  Sequence seq;
  seq.root = out;
  seq.manifest = out / kManifestName;
  seq.name = opt.name.empty() ? root.filename().string() : opt.name;
  seq.kind = SequenceKind::Stereo;
  seq.size = image_size(left_dir / names.front());
  if (image_size(right_dir / names.front()) != seq.size)
    throw Error((right_dir / names.front()).string(), "", "the right image's size differs from the left one's");
  const KittiCalibration calib = read_kitti_calibration(root / "calib.txt");
  seq.calibration.fx = calib.fx;
  seq.calibration.fy = calib.fy;
  seq.calibration.cx = calib.cx;
  seq.calibration.cy = calib.cy;
  seq.calibration.baseline = calib.baseline;
  seq.calibration.disparity_offset = opt.disparity_offset.value_or(calib.cx_right - calib.cx);
  seq.camera_height = opt.camera_height;
  const std::vector<double> times = frame_times(root, names.size(), opt.fps);
  for (std::size_t i = 0; i < names.size(); ++i) {
    FrameEntry e;
    e.left = left_dir / names[i];
    e.right = right_dir / names[i];
    e.time = times[i];
    seq.frames.push_back(e);
  }
  const fs::path poses = !opt.poses.empty() ? opt.poses : (fs::exists(root / "poses.txt", ec) ? root / "poses.txt" : fs::path());
  if (!poses.empty()) {
    seq.gt_poses = read_kitti_poses(poses, opt.camera_height);
    if (seq.gt_poses.size() != seq.frames.size())
      throw Error(poses.string(), "", std::to_string(seq.gt_poses.size()) + " poses for " + std::to_string(seq.frames.size()) + " frames");
  }
  if (opt.classes.empty()) {
    seq.classes = camvid_road_classes(&seq.void_class);
  } else {
    CamvidClasses c = read_camvid_classes(opt.classes);
    seq.classes = std::move(c.classes);
    seq.void_class = c.void_class;
  }
  seq.extra = {{"source", "kitti"}, {"folder", root.string()}, {"camera_height_assumed", opt.camera_height}};
  check_before_saving(seq);
  fs::create_directories(out, ec);
  if (ec) throw Error(out.string(), "", "cannot create the folder: " + ec.message());
  save_sequence(seq);
  return load_sequence(out);  // what a reader sees, validated
}

}  // namespace smseg::sequence
