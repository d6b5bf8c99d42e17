#include "smseg/sequence/camvid.hpp"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "smseg/sequence/image_file.hpp"

namespace smseg::features {

namespace {

struct CsvTable {
  fs::path file;
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  std::vector<int> line_of_row;

  int column(const std::string& name) const {
    auto it = std::find(header.begin(), header.end(), name);
    if (it == header.end()) throw Error(file.string(), name, "missing column");
    return static_cast<int>(it - header.begin());
  }
};

std::vector<std::string> split_csv_line(const std::string& line) {
  std::vector<std::string> cells;
  std::string cell;
  std::istringstream ss(line);
  while (std::getline(ss, cell, ',')) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

/// Whether text is well-formed UTF-8 (no overlong forms, surrogates or code points above U+10FFFF).
/// The cells become names in sequence.json, and JSON text must be UTF-8.
bool is_utf8(std::string_view text) {
  std::size_t i = 0;
  while (i < text.size()) {
    const auto byte = [&](std::size_t k) { return static_cast<unsigned char>(text[k]); };
    const unsigned char c = byte(i);
    std::size_t extra = 0;
    unsigned lo = 0x80, hi = 0xBF;  // the allowed range of the second byte
    if (c < 0x80) {
      ++i;
      continue;
    } else if (c >= 0xC2 && c <= 0xDF) {
      extra = 1;
    } else if (c >= 0xE0 && c <= 0xEF) {
      extra = 2;
      if (c == 0xE0) lo = 0xA0;
      if (c == 0xED) hi = 0x9F;
    } else if (c >= 0xF0 && c <= 0xF4) {
      extra = 3;
      if (c == 0xF0) lo = 0x90;
      if (c == 0xF4) hi = 0x8F;
    } else {
      return false;
    }
    if (i + extra >= text.size()) return false;  // truncated sequence
    if (byte(i + 1) < lo || byte(i + 1) > hi) return false;
    for (std::size_t k = 2; k <= extra; ++k)
      if (byte(i + k) < 0x80 || byte(i + k) > 0xBF) return false;
    i += extra + 1;
  }
  return true;
}

CsvTable read_csv(const fs::path& file) {
  const std::string text = read_file(file);
  CsvTable t;
  t.file = file;
  std::istringstream in(text);
  std::string line;
  int lineno = 0;
  while (std::getline(in, line)) {
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.empty()) continue;
    if (!is_utf8(line)) throw Error(file.string(), "line " + std::to_string(lineno), "is not UTF-8 text");
    auto cells = split_csv_line(line);
    if (t.header.empty()) {
      t.header = std::move(cells);
      continue;
    }
    if (cells.size() != t.header.size())
      throw Error(file.string(), "line " + std::to_string(lineno),
                  "has " + std::to_string(cells.size()) + " cells, the header has " + std::to_string(t.header.size()));
    t.rows.push_back(std::move(cells));
    t.line_of_row.push_back(lineno);
  }
  if (t.header.empty()) throw Error(file.string(), "", "empty CSV file");
  return t;
}

long parse_long(const CsvTable& t, std::size_t row, int col) {
  const std::string& s = t.rows[row][col];
  try {
    std::size_t used = 0;
    const long v = std::stol(s, &used);
    if (used == s.size()) return v;
  } catch (const std::exception&) {
  }
  throw Error(t.file.string(), "line " + std::to_string(t.line_of_row[row]) + ", " + t.header[col],
              "expected an integer, found \"" + s + "\"");
}

/// A number of row's column col that must lie in lo..hi (a class index, a colour, a video frame).
long parse_in_range(const CsvTable& t, std::size_t row, int col, long lo, long hi) {
  const long v = parse_long(t, row, col);
  if (v < lo || v > hi)
    throw Error(t.file.string(), "line " + std::to_string(t.line_of_row[row]) + ", " + t.header[col],
                "is " + std::to_string(v) + ", expected " + std::to_string(lo) + ".." + std::to_string(hi));
  return v;
}

/// CamVid's frame numbers count 30 Hz video frames: a billion is ten years of video, and the bound keeps
/// the differences between frame numbers far from overflowing.
constexpr long kMaxVideoFrame = 1000000000;

}  // namespace

CamvidClasses read_camvid_classes(const fs::path& file) {
  // index,name,r,g,b; the row named Void (any case) is the ignore label.
  const CsvTable classes = read_csv(file);
  const int ci = classes.column("index"), cn = classes.column("name"), cr = classes.column("r"),
            cg = classes.column("g"), cb = classes.column("b");
  CamvidClasses out;
  std::optional<ClassInfo> void_class;
  for (std::size_t r = 0; r < classes.rows.size(); ++r) {
    ClassInfo c;
    c.name = classes.rows[r][cn];
    c.file_value = static_cast<int>(parse_in_range(classes, r, ci, 0, 255));  // a label image's 8-bit value
    const long rgb[3] = {parse_long(classes, r, cr), parse_long(classes, r, cg), parse_long(classes, r, cb)};
    for (int k = 0; k < 3; ++k) {
      if (rgb[k] < 0 || rgb[k] > 255)
        throw Error(classes.file.string(), "line " + std::to_string(classes.line_of_row[r]), "colour out of 0..255");
      c.rgb[k] = static_cast<std::uint8_t>(rgb[k]);
    }
    std::string lower = c.name;
    std::transform(lower.begin(), lower.end(), lower.begin(), [](unsigned char ch) { return std::tolower(ch); });
    if (lower == "void") {
      void_class = c;
    } else {
      out.classes.push_back(c);
    }
  }
  if (!void_class) throw Error(classes.file.string(), "name", "no Void class (the ignore label)");
  if (out.classes.empty()) throw Error(classes.file.string(), "", "no classes");
  out.void_class = *void_class;
  return out;
}

void CamvidImportOptions::validate() const {
  if (splits.empty()) throw Error("", "--split", "name at least one split");
  if (!(video_fps > 0)) throw Error("", "video_fps", "must be positive");
  if (!(camera_height > 0)) throw Error("", "--camera-height", "must be positive (metres)");
  if (focal && !(*focal > 0)) throw Error("", "--focal", "must be positive (pixels)");
  if (max_gap < 1) throw Error("", "max_gap", "must be at least 1");
}

std::vector<CamvidRun> import_camvid(const fs::path& dir, const fs::path& out, const CamvidImportOptions& opt) {
  opt.validate();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw Error(dir.string(), "", "no such folder");
  const fs::path root = fs::canonical(dir);

  const auto [class_list, void_class] = read_camvid_classes(root / "classes.csv");

  // Frames: sequence,frame,split,image,label,gap...
  const CsvTable frames = read_csv(root / "frames.csv");
  const int fs_ = frames.column("sequence"), ff = frames.column("frame"), fsp = frames.column("split"),
            fi = frames.column("image"), fl = frames.column("label");
  const std::set<std::string> wanted(opt.splits.begin(), opt.splits.end());
  std::set<std::string> seen_splits;
  for (const auto& row : frames.rows) seen_splits.insert(row[fsp]);
  for (const auto& s : wanted)
    if (!seen_splits.count(s)) {
      std::string have;
      for (const auto& x : seen_splits) have += (have.empty() ? "" : ", ") + x;
      throw Error(frames.file.string(), "split", "no frames of split \"" + s + "\" (it has: " + have + ")");
    }

  struct Pending {
    CamvidRun run;
    std::vector<std::size_t> rows;
    long last_frame = 0;
  };
  std::vector<Pending> runs;
  for (std::size_t r = 0; r < frames.rows.size(); ++r) {
    const auto& row = frames.rows[r];
    if (!wanted.count(row[fsp])) continue;
    const long frame = parse_in_range(frames, r, ff, 0, kMaxVideoFrame);
    bool extend = false;
    if (!runs.empty()) {
      Pending& p = runs.back();
      const long gap = frame - p.last_frame;
      extend = p.run.camvid_sequence == row[fs_] && p.run.split == row[fsp] && gap > 0 && gap <= opt.max_gap &&
               (p.run.frame_gap == 0 || (gap * 2 > p.run.frame_gap && gap < p.run.frame_gap * 2));
      // The rows of one split must be contiguous in frames.csv to be one run; a gap of another rate
      // (2 vs 30 video frames) starts a new run.
      if (extend && p.run.frame_gap == 0) p.run.frame_gap = static_cast<int>(gap);
    }
    if (!extend) {
      Pending p;
      p.run.camvid_sequence = row[fs_];
      p.run.split = row[fsp];
      runs.push_back(std::move(p));
    }
    runs.back().rows.push_back(r);
    runs.back().last_frame = frame;
  }
  if (runs.empty()) throw Error(frames.file.string(), "", "no frames for the splits asked for");

  std::vector<CamvidRun> result;
  Json index = {{"format", "smseg-camvid-import"}, {"version", 1}, {"source", root.string()},
                {"splits", opt.splits}, {"sequences", Json::array()}};
  for (auto& p : runs) {
    Sequence seq;
    const auto stem = [&](std::size_t r) { return fs::path(frames.rows[r][fi]).stem().string(); };
    const std::string first = stem(p.rows.front()), last = stem(p.rows.back());
    const auto us = last.rfind('_');
    p.run.name = first + "-" + (us == std::string::npos ? last : last.substr(us + 1));
    p.run.frames = static_cast<int>(p.rows.size());
    p.run.folder = out / p.run.name;
    seq.root = p.run.folder;
    seq.manifest = seq.root / kManifestName;
    seq.name = p.run.name;
    seq.kind = SequenceKind::Mono;
    seq.label_encoding = LabelEncoding::Index;
    seq.classes = class_list;
    seq.void_class = void_class;
    seq.camera_height = opt.camera_height;
    const long frame0 = parse_in_range(frames, p.rows.front(), ff, 0, kMaxVideoFrame);
    for (std::size_t k = 0; k < p.rows.size(); ++k) {
      const std::size_t r = p.rows[k];
      const auto& row = frames.rows[r];
      FrameEntry e;
      e.left = root / row[fi];
      e.label = root / row[fl];
      const std::string where = "line " + std::to_string(frames.line_of_row[r]);
      if (const std::string why = why_not_a_file(e.left); !why.empty())
        throw Error(frames.file.string(), where, "image " + e.left.string() + " " + why);
      if (const std::string why = why_not_a_file(e.label); !why.empty())
        throw Error(frames.file.string(), where, "label " + e.label.string() + " " + why);
      e.time = double(parse_in_range(frames, r, ff, 0, kMaxVideoFrame) - frame0) / opt.video_fps;
      seq.frames.push_back(e);
      seq.labelled_frames.push_back(static_cast<int>(k));
    }
    seq.size = read_image_file(seq.frames.front().left, cv::IMREAD_UNCHANGED).size();
    seq.calibration.cx = (seq.size.width - 1) / 2.0;
    seq.calibration.cy = (seq.size.height - 1) / 2.0;
    if (opt.focal) seq.calibration.fx = seq.calibration.fy = *opt.focal;
    seq.extra = {{"source", "camvid"}, {"camvid_sequence", p.run.camvid_sequence}, {"split", p.run.split},
                 {"video_frames", {frame0, p.last_frame}}, {"frame_gap", p.run.frame_gap},
                 {"camera_height_note", "assumed, not measured (CamVid gives no height)"}};
    save_sequence(seq);
    index["sequences"].push_back({{"name", p.run.name}, {"split", p.run.split}, {"frames", p.run.frames},
                                  {"frame_gap", p.run.frame_gap}, {"camvid_sequence", p.run.camvid_sequence},
                                  {"path", p.run.name + "/" + kManifestName}});
    result.push_back(p.run);
  }
  write_json_atomic(out / "index.json", index);
  return result;
}

}  // namespace smseg::features
