#include "smseg/sequence/sequence.hpp"

#include "smseg/sequence/image_file.hpp"
#include "sequence_parse.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <new>
#include <set>
#include <unordered_map>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

namespace smseg::sequence {

namespace {

const char* kind_name(SequenceKind k) { return k == SequenceKind::Stereo ? "stereo" : "mono"; }
const char* encoding_name(LabelEncoding e) { return e == LabelEncoding::Rgb ? "rgb" : "index"; }

ClassInfo parse_class(const JsonView& c) {
  ClassInfo info;
  info.name = c.str("name");
  if (info.name.empty()) c.fail("must not be empty", "name");
  const auto value = c.integer("value");
  if (value < 0 || value > 255) c.fail("must be in 0..255", "value");
  info.file_value = static_cast<int>(value);
  const JsonView col = c.at("colour");
  if (col.size() != 3) col.fail("expected [r, g, b]");
  for (std::size_t k = 0; k < 3; ++k) {
    const auto v = col.at(k).as_integer();
    if (v < 0 || v > 255) col.at(k).fail("must be in 0..255");
    info.rgb[k] = static_cast<std::uint8_t>(v);
  }
  return info;
}

Json class_to_json(const ClassInfo& c) {
  return Json{{"name", c.name}, {"value", c.file_value}, {"colour", {c.rgb[0], c.rgb[1], c.rgb[2]}}};
}

fs::path optional_path(const JsonView& f, std::string_view key) {
  auto v = f.maybe(key);
  if (!v) return {};
  const std::string s = v->as_str();
  if (s.empty()) v->fail("must not be empty");
  return fs::path(s);
}

void require_file(const Sequence& seq, const fs::path& p, const std::string& what) {
  const fs::path full = seq.resolve(p);
  if (const std::string why = why_not_a_file(full); !why.empty())
    throw Error(seq.manifest.string(), what, "names " + full.string() + ", which " + why);
}

void check_size(const Sequence& seq, const fs::path& full, const cv::Mat& m) {
  if (m.size() != seq.size)
    throw Error(full.string(), "",
                "image is " + std::to_string(m.cols) + "x" + std::to_string(m.rows) + ", the sequence " +
                    seq.manifest.string() + " says " + std::to_string(seq.size.width) + "x" +
                    std::to_string(seq.size.height));
}

/// An image of the sequence, refused unless of the sequence's size (a PNG before it is decoded).
cv::Mat read_sequence_image(const Sequence& seq, const fs::path& full, int flags) {
  const ExpectedImageSize expected{seq.size, "the sequence " + seq.manifest.string()};
  return read_image_file(full, flags, &expected);
}

void check_frame(const Sequence& seq, int frame) {
  if (frame < 0 || frame >= seq.frame_count())
    throw Error(seq.manifest.string(), "frames",
                "frame " + std::to_string(frame) + " out of range 0.." + std::to_string(seq.frame_count() - 1));
}

}  // namespace

int Sequence::range_end(int first, int last) const {
  const int end = last < 0 ? frame_count() : last;
  if (first >= frame_count() || end > frame_count())
    throw Error(manifest.string(), "frames",
                "frame range " + std::to_string(first) + ".." + std::to_string(end) + " is outside the sequence's " +
                    std::to_string(frame_count()) + " frames");
  return end;
}

bool Sequence::is_labelled(int frame) const {
  return std::binary_search(labelled_frames.begin(), labelled_frames.end(), frame);
}

namespace {

/// The manifest a sequence argument names (a folder holding sequence.json, or the file itself).
fs::path manifest_of(const fs::path& dir_or_manifest) {
  std::error_code ec;
  const fs::path manifest = fs::is_directory(dir_or_manifest, ec) ? dir_or_manifest / kManifestName : dir_or_manifest;
  if (!fs::exists(manifest, ec)) {
    if (fs::is_directory(dir_or_manifest, ec))
      throw Error(dir_or_manifest.string(), "", std::string("not a sequence: no ") + kManifestName + " in it");
    throw Error(manifest.string(), "", "no such sequence (file or folder)");
  }
  return manifest;
}

void parse_kind_and_size(const JsonView& j, Sequence& seq) {
  seq.name = j.has("name") ? j.str("name") : seq.root.filename().string();
  const std::string kind = j.str("kind");
  if (kind == "stereo") {
    seq.kind = SequenceKind::Stereo;
  } else if (kind == "mono") {
    seq.kind = SequenceKind::Mono;
  } else {
    j.fail("is \"" + kind + "\", expected \"stereo\" or \"mono\"", "kind");
  }
  const JsonView size = j.at("image_size");
  const auto w = size.integer("width"), h = size.integer("height");
  if (w <= 0 || h <= 0 || w > 20000 || h > 20000) size.fail("width and height must be in 1..20000");
  seq.size = cv::Size(static_cast<int>(w), static_cast<int>(h));
}

void parse_calibration(const JsonView& j, Sequence& seq) {
  const JsonView cal = j.at("calibration");
  if (auto v = cal.maybe("fx")) seq.calibration.fx = v->as_num();
  if (auto v = cal.maybe("fy")) seq.calibration.fy = v->as_num();
  if (auto v = cal.maybe("baseline")) seq.calibration.baseline = v->as_num();
  seq.calibration.cx = cal.num("cx");
  seq.calibration.cy = cal.num("cy");
  if (auto v = cal.maybe("disparity_offset")) {
    seq.calibration.disparity_offset = v->as_num();
    if (!(std::abs(seq.calibration.disparity_offset) <= 1000)) v->fail("must be a number of pixels in -1000..1000");
  }
  for (const auto& [key, v] : {std::pair{"fx", seq.calibration.fx}, std::pair{"fy", seq.calibration.fy},
                               std::pair{"baseline", seq.calibration.baseline}}) {
    if (v && !(*v > 0 && std::isfinite(*v))) cal.fail("must be a positive number", key);
  }
  if (seq.calibration.fx.has_value() != seq.calibration.fy.has_value())
    cal.fail("give both fx and fy, or neither (unknown focal length)");
  if (seq.kind == SequenceKind::Stereo) {
    if (!seq.calibration.fx) cal.fail("a stereo sequence needs the focal length", "fx");
    if (!seq.calibration.baseline) cal.fail("a stereo sequence needs the baseline (metres)", "baseline");
  }
  if (auto v = j.maybe("camera_height")) {
    seq.camera_height = v->as_num();
    if (!(*seq.camera_height > 0)) v->fail("must be positive (metres above the ground)");
  }
}

/// No two classes of one name, nor of one label value (index encoding) or colour (rgb encoding): a
/// label image could not tell them apart.
void check_classes_distinct(const JsonView& labels, const Sequence& seq) {
  std::set<std::string> names;
  std::set<int> values;
  std::set<std::array<std::uint8_t, 3>> colours;
  auto add = [&](const ClassInfo& c, const std::string& where) {
    if (!names.insert(c.name).second) labels.fail("class name \"" + c.name + "\" appears twice", where);
    if (seq.label_encoding == LabelEncoding::Index && !values.insert(c.file_value).second)
      labels.fail("label value " + std::to_string(c.file_value) + " is used twice", where);
    if (seq.label_encoding == LabelEncoding::Rgb && !colours.insert(c.rgb).second)
      labels.fail("class \"" + c.name + "\": its colour is used by another class", where);
  };
  for (std::size_t i = 0; i < seq.classes.size(); ++i) add(seq.classes[i], "classes[" + std::to_string(i) + "]");
  add(seq.void_class, "void");
}

void parse_classes(const JsonView& labels, Sequence& seq) {
  const std::string enc = labels.str("encoding");
  if (enc == "rgb") {
    seq.label_encoding = LabelEncoding::Rgb;
  } else if (enc == "index") {
    seq.label_encoding = LabelEncoding::Index;
  } else {
    labels.fail("is \"" + enc + "\", expected \"rgb\" or \"index\"", "encoding");
  }
  const JsonView classes = labels.at("classes");
  if (classes.size() == 0) classes.fail("the class list is empty");
  if (classes.size() > 254) classes.fail("at most 254 classes are supported");
  for (std::size_t i = 0; i < classes.size(); ++i) seq.classes.push_back(parse_class(classes.at(i)));
  seq.void_class = parse_class(labels.at("void"));
  check_classes_distinct(labels, seq);
}

FrameEntry parse_frame(const JsonView& frames, std::size_t i, const Sequence& seq) {
  const JsonView f = frames.at(i);
  FrameEntry e;
  e.left = fs::path(f.str("left"));
  e.right = optional_path(f, "right");
  e.disparity = optional_path(f, "disparity");
  e.label = optional_path(f, "label");
  e.gt_depth = optional_path(f, "gt_depth");
  e.instances = optional_path(f, "instances");
  // Times are given for every frame or for none (then the frame index is the time): a missing one
  // among given ones is named where it is missing, not at the next frame that seems out of order.
  const bool timed = frames.at(0).has("time");
  if (f.has("time") != timed)
    f.fail(timed ? "missing (frames[0] has a time, so every frame needs one)"
                 : "given, but frames[0] has none (give every frame a time, or none)",
           "time");
  e.time = timed ? f.num("time") : static_cast<double>(i);
  if (seq.kind == SequenceKind::Stereo && e.right.empty() && e.disparity.empty())
    f.fail("a stereo sequence needs a \"right\" image or a \"disparity\" for every frame");
  if (i > 0 && !(e.time > seq.frames.back().time)) f.fail("frame times must increase", "time");
  return e;
}

void parse_labelled_frames(const JsonView& labels, Sequence& seq) {
  const JsonView lf = labels.at("labelled_frames");
  for (std::size_t i = 0; i < lf.size(); ++i) {
    const auto idx = lf.at(i).as_integer();
    if (idx < 0 || idx >= seq.frame_count())
      lf.at(i).fail("labelled frame " + std::to_string(idx) + " is out of range (the sequence has " +
                    std::to_string(seq.frame_count()) + " frames)");
    if (!seq.labelled_frames.empty() && idx <= seq.labelled_frames.back())
      lf.at(i).fail("labelled frames must be ascending and unique");
    if (seq.frames[idx].label.empty())
      lf.at(i).fail("frame " + std::to_string(idx) + " is marked labelled but frames[" + std::to_string(idx) +
                    "] has no \"label\"");
    seq.labelled_frames.push_back(static_cast<int>(idx));
  }
}

void parse_ground_truth_poses(const JsonView& j, Sequence& seq) {
  const auto gt = j.maybe("ground_truth");
  const auto poses = gt ? gt->maybe("poses") : std::nullopt;
  if (!poses) return;
  if (poses->size() != seq.frames.size())
    poses->fail("has " + std::to_string(poses->size()) + " poses for " + std::to_string(seq.frames.size()) + " frames");
  for (std::size_t i = 0; i < poses->size(); ++i) {
    const JsonView p = poses->at(i);
    Pose pose;
    const JsonView R = p.at("R"), t = p.at("t");
    if (R.size() != 9) R.fail("expected 9 numbers (row-major 3x3)");
    if (t.size() != 3) t.fail("expected 3 numbers");
    for (std::size_t k = 0; k < 9; ++k) pose.R[k] = R.at(k).as_num();
    for (std::size_t k = 0; k < 3; ++k) pose.t[k] = t.at(k).as_num();
    if (!is_rotation(pose.R)) R.fail("is not a rotation matrix");
    seq.gt_poses.push_back(pose);
  }
}

/// Every file the frames name must exist (decoding is left to the loaders / validate_images).
void require_named_files(const Sequence& seq) {
  for (int i = 0; i < seq.frame_count(); ++i) {
    const auto& e = seq.frames[i];
    const std::string where = "frames[" + std::to_string(i) + "]";
    require_file(seq, e.left, where + ".left");
    if (!e.right.empty()) require_file(seq, e.right, where + ".right");
    if (!e.disparity.empty()) require_file(seq, e.disparity, where + ".disparity");
    if (!e.label.empty()) require_file(seq, e.label, where + ".label");
    if (!e.gt_depth.empty()) require_file(seq, e.gt_depth, where + ".gt_depth");
    if (!e.instances.empty()) require_file(seq, e.instances, where + ".instances");
  }
}

}  // namespace

bool is_rotation(const std::array<double, 9>& R) {
  // As the tracks reader checks its poses: R R^T = I to 1e-4, and no reflection.
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) {
      double dot = 0;
      for (int k = 0; k < 3; ++k) dot += R[3 * r + k] * R[3 * c + k];
      if (!(std::abs(dot - (r == c ? 1.0 : 0.0)) <= 1e-4)) return false;
    }
  const double det = R[0] * (R[4] * R[8] - R[5] * R[7]) - R[1] * (R[3] * R[8] - R[5] * R[6]) +
                     R[2] * (R[3] * R[7] - R[4] * R[6]);
  return det > 0;
}

Sequence sequence_from_json(const Json& doc, const fs::path& manifest) {
  Sequence seq;
  seq.manifest = manifest;
  seq.root = manifest.parent_path();
  const JsonView j(doc, manifest);
  check_format(j, kSequenceFormat, {kSequenceVersion});
  parse_kind_and_size(j, seq);
  parse_calibration(j, seq);
  const JsonView labels = j.at("labels");
  parse_classes(labels, seq);
  const JsonView frames = j.at("frames");
  if (frames.size() == 0) frames.fail("the sequence has no frames");
  for (std::size_t i = 0; i < frames.size(); ++i) seq.frames.push_back(parse_frame(frames, i, seq));
  parse_labelled_frames(labels, seq);
  parse_ground_truth_poses(j, seq);
  if (j.has("extra")) seq.extra = j.at("extra").json();
  require_named_files(seq);
  return seq;
}

Sequence load_sequence(const fs::path& dir_or_manifest) {
  const fs::path manifest = manifest_of(dir_or_manifest);
  const Json doc = read_json(manifest);
  try {
    return sequence_from_json(doc, manifest);
  } catch (const std::bad_alloc&) {  // the parsed file and the sequence side by side did not fit
    throw Error(manifest.string(), "", "out of memory reading the sequence it describes");
  }
}

void check_before_saving(const Sequence& seq) {
  // Through the text a reader will parse: a number JSON cannot hold (inf) is null there, not here.
  sequence_from_json(Json::parse(json_text(sequence_to_json(seq), seq.manifest)), seq.manifest);
}

Json sequence_to_json(const Sequence& seq) {
  Json j;
  j["format"] = kSequenceFormat;
  j["version"] = kSequenceVersion;
  j["name"] = seq.name;
  j["kind"] = kind_name(seq.kind);
  j["image_size"] = {{"width", seq.size.width}, {"height", seq.size.height}};
  Json cal = {{"cx", seq.calibration.cx}, {"cy", seq.calibration.cy}};
  if (seq.calibration.fx) cal["fx"] = *seq.calibration.fx;
  if (seq.calibration.fy) cal["fy"] = *seq.calibration.fy;
  if (seq.calibration.baseline) cal["baseline"] = *seq.calibration.baseline;
  if (seq.calibration.disparity_offset != 0) cal["disparity_offset"] = seq.calibration.disparity_offset;
  j["calibration"] = cal;
  if (seq.camera_height) j["camera_height"] = *seq.camera_height;
  Json classes = Json::array();
  for (const auto& c : seq.classes) classes.push_back(class_to_json(c));
  j["labels"] = {{"encoding", encoding_name(seq.label_encoding)},
                 {"classes", classes},
                 {"void", class_to_json(seq.void_class)},
                 {"labelled_frames", seq.labelled_frames}};
  Json frames = Json::array();
  for (const auto& e : seq.frames) {
    Json f = {{"left", e.left.string()}, {"time", e.time}};
    if (!e.right.empty()) f["right"] = e.right.string();
    if (!e.disparity.empty()) f["disparity"] = e.disparity.string();
    if (!e.label.empty()) f["label"] = e.label.string();
    if (!e.gt_depth.empty()) f["gt_depth"] = e.gt_depth.string();
    if (!e.instances.empty()) f["instances"] = e.instances.string();
    frames.push_back(std::move(f));
  }
  j["frames"] = std::move(frames);
  if (!seq.gt_poses.empty()) {
    Json poses = Json::array();
    for (const auto& p : seq.gt_poses) poses.push_back({{"R", p.R}, {"t", p.t}});
    j["ground_truth"] = {{"poses", std::move(poses)},
                         {"pose_convention", "camera-to-world; camera x right, y down, z forward; world Y up"}};
  }
  if (!seq.extra.empty()) j["extra"] = seq.extra;
  return j;
}

void save_sequence(const Sequence& seq) {
  check_before_saving(seq);  // a manifest that would not read back never replaces the one there
  write_json_atomic(seq.root / kManifestName, sequence_to_json(seq));
}

cv::Mat Sequence::load_left(int frame) const {
  check_frame(*this, frame);
  const fs::path full = resolve(frames[frame].left);
  cv::Mat m = read_sequence_image(*this, full, cv::IMREAD_COLOR);
  return m;
}

cv::Mat Sequence::load_left_gray(int frame) const {
  check_frame(*this, frame);
  const fs::path full = resolve(frames[frame].left);
  cv::Mat m = read_sequence_image(*this, full, cv::IMREAD_GRAYSCALE);
  return m;
}

cv::Mat Sequence::load_right_gray(int frame) const {
  check_frame(*this, frame);
  if (frames[frame].right.empty())
    throw Error(manifest.string(), "frames[" + std::to_string(frame) + "].right", "no right image");
  const fs::path full = resolve(frames[frame].right);
  cv::Mat m = read_sequence_image(*this, full, cv::IMREAD_GRAYSCALE);
  return m;
}

cv::Mat Sequence::load_disparity(int frame) const {
  check_frame(*this, frame);
  if (frames[frame].disparity.empty())
    throw Error(manifest.string(), "frames[" + std::to_string(frame) + "].disparity", "no disparity map");
  const fs::path full = resolve(frames[frame].disparity);
  cv::Mat d;
  const std::string ext = full.extension().string();
  if (ext == ".npy") {
    d = read_npy_f32(full);
  } else {
    cv::Mat raw = read_sequence_image(*this, full, cv::IMREAD_UNCHANGED);
    if (raw.channels() != 1) throw Error(full.string(), "", "a disparity map must have one channel");
    if (raw.depth() == CV_16U) {
      raw.convertTo(d, CV_32F, 1.0 / 256.0);  // KITTI convention: value / 256, 0 = unknown
    } else {
      raw.convertTo(d, CV_32F);
    }
  }
  check_size(*this, full, d);
  cv::patchNaNs(d, -1.0);
  d.setTo(-1.0f, d == std::numeric_limits<float>::infinity());
  return d;
}

cv::Mat Sequence::load_gt_depth(int frame) const {
  check_frame(*this, frame);
  if (frames[frame].gt_depth.empty())
    throw Error(manifest.string(), "frames[" + std::to_string(frame) + "].gt_depth", "no ground-truth depth");
  const fs::path full = resolve(frames[frame].gt_depth);
  cv::Mat d = read_npy_f32(full);
  check_size(*this, full, d);
  return d;
}

bool Sequence::has_instances(int frame) const {
  check_frame(*this, frame);
  return !frames[frame].instances.empty();
}

cv::Mat Sequence::load_instances(int frame) const {
  check_frame(*this, frame);
  if (frames[frame].instances.empty())
    throw Error(manifest.string(), "frames[" + std::to_string(frame) + "].instances", "frame has no instance image");
  const fs::path full = resolve(frames[frame].instances);
  cv::Mat m = read_sequence_image(*this, full, cv::IMREAD_UNCHANGED);
  if (m.type() != CV_8UC1) throw Error(full.string(), "", "an instance image must be 8-bit with one channel");
  return m;
}

cv::Mat Sequence::load_labels(int frame) const {
  check_frame(*this, frame);
  if (frames[frame].label.empty())
    throw Error(manifest.string(), "frames[" + std::to_string(frame) + "].label", "frame has no label image");
  const fs::path full = resolve(frames[frame].label);
  cv::Mat out(size, CV_8UC1);
  if (label_encoding == LabelEncoding::Index) {
    cv::Mat raw = read_sequence_image(*this, full, cv::IMREAD_UNCHANGED);
    if (raw.type() != CV_8UC1)
      throw Error(full.string(), "", "an index-encoded label image must be 8-bit with one channel");
    std::array<int, 256> lut;
    lut.fill(-1);
    for (std::size_t c = 0; c < classes.size(); ++c) lut[classes[c].file_value] = static_cast<int>(c);
    lut[void_class.file_value] = kVoid;
    for (int y = 0; y < raw.rows; ++y) {
      const std::uint8_t* in = raw.ptr<std::uint8_t>(y);
      std::uint8_t* o = out.ptr<std::uint8_t>(y);
      for (int x = 0; x < raw.cols; ++x) {
        const int v = lut[in[x]];
        if (v < 0)
          throw Error(full.string(), "",
                      "pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") has label value " +
                          std::to_string(in[x]) + ", which is not in the class list");
        o[x] = static_cast<std::uint8_t>(v);
      }
    }
  } else {
    cv::Mat raw = read_sequence_image(*this, full, cv::IMREAD_COLOR);
    std::unordered_map<std::uint32_t, std::uint8_t> lut;
    auto key = [](std::uint8_t r, std::uint8_t g, std::uint8_t b) {
      return (std::uint32_t(r) << 16) | (std::uint32_t(g) << 8) | b;
    };
    for (std::size_t c = 0; c < classes.size(); ++c)
      lut[key(classes[c].rgb[0], classes[c].rgb[1], classes[c].rgb[2])] = static_cast<std::uint8_t>(c);
    lut[key(void_class.rgb[0], void_class.rgb[1], void_class.rgb[2])] = kVoid;
    std::uint32_t last_key = 0xffffffffu;
    std::uint8_t last_val = 0;
    for (int y = 0; y < raw.rows; ++y) {
      const cv::Vec3b* in = raw.ptr<cv::Vec3b>(y);
      std::uint8_t* o = out.ptr<std::uint8_t>(y);
      for (int x = 0; x < raw.cols; ++x) {
        const std::uint32_t k = key(in[x][2], in[x][1], in[x][0]);  // BGR in memory
        if (k != last_key) {
          auto it = lut.find(k);
          if (it == lut.end())
            throw Error(full.string(), "",
                        "pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") has colour (" +
                            std::to_string(in[x][2]) + ", " + std::to_string(in[x][1]) + ", " +
                            std::to_string(in[x][0]) + "), which is not a class colour");
          last_key = k;
          last_val = it->second;
        }
        o[x] = last_val;
      }
    }
  }
  return out;
}

void validate_images(const Sequence& seq) {
  for (int i = 0; i < seq.frame_count(); ++i) {
    seq.load_left_gray(i);
    const auto& e = seq.frames[i];
    if (!e.right.empty()) seq.load_right_gray(i);
    if (!e.disparity.empty()) seq.load_disparity(i);
    if (!e.label.empty()) seq.load_labels(i);
    if (!e.gt_depth.empty()) seq.load_gt_depth(i);
    if (!e.instances.empty()) seq.load_instances(i);
  }
}

cv::Mat colour_labels(const cv::Mat& labels, const Sequence& seq) {
  CV_Assert(labels.type() == CV_8UC1);
  std::array<cv::Vec3b, 256> lut;
  lut.fill(cv::Vec3b(seq.void_class.rgb[2], seq.void_class.rgb[1], seq.void_class.rgb[0]));
  for (std::size_t c = 0; c < seq.classes.size(); ++c)
    lut[c] = cv::Vec3b(seq.classes[c].rgb[2], seq.classes[c].rgb[1], seq.classes[c].rgb[0]);
  cv::Mat out(labels.size(), CV_8UC3);
  for (int y = 0; y < labels.rows; ++y) {
    const std::uint8_t* in = labels.ptr<std::uint8_t>(y);
    cv::Vec3b* o = out.ptr<cv::Vec3b>(y);
    for (int x = 0; x < labels.cols; ++x) o[x] = lut[in[x]];
  }
  return out;
}

void write_image_atomic(const fs::path& path, const cv::Mat& image) {
  std::vector<std::uint8_t> buf;
  bool ok = false;
  try {
    ok = cv::imencode(path.extension().string(), image, buf);
  } catch (const cv::Exception& e) {
    throw Error(path.string(), "", std::string("cannot encode the image: ") + e.what());
  }
  if (!ok) throw Error(path.string(), "", "cannot encode the image");
  write_file_atomic(path, std::string_view(reinterpret_cast<const char*>(buf.data()), buf.size()));
}

}  // namespace smseg::sequence
