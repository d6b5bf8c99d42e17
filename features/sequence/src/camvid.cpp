#include "smseg/sequence/camvid.hpp"

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <sstream>

#include <opencv2/imgcodecs.hpp>

#include "smseg/sequence/image_file.hpp"
#include "sequence_parse.hpp"

namespace smseg::sequence {

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
  int lineno = 0;
  // Lines are cut from the text where it lies (a copy of a 256 MiB file would double what it takes).
  for (std::size_t begin = 0; begin < text.size();) {
    const std::size_t newline = text.find('\n', begin);
    const std::size_t end = newline == std::string::npos ? text.size() : newline;
    std::string_view line(text.data() + begin, end - begin);
    begin = end + 1;
    ++lineno;
    if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
    if (line.empty()) continue;
    if (!is_utf8(line)) throw Error(file.string(), "line " + std::to_string(lineno), "is not UTF-8 text");
    auto cells = split_csv_line(std::string(line));
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

namespace {

std::string lower_case(std::string text) {
  std::transform(text.begin(), text.end(), text.begin(), [](unsigned char ch) { return std::tolower(ch); });
  return text;
}

/// One row of classes.csv: its class, and whether it is the Void row (any case).
ClassInfo parse_class_row(const CsvTable& classes, std::size_t r) {
  const int ci = classes.column("index"), cn = classes.column("name"), cr = classes.column("r"),
            cg = classes.column("g"), cb = classes.column("b");
  ClassInfo c;
  c.name = classes.rows[r][cn];
  c.file_value = static_cast<int>(parse_in_range(classes, r, ci, 0, 255));  // a label image's 8-bit value
  const long rgb[3] = {parse_long(classes, r, cr), parse_long(classes, r, cg), parse_long(classes, r, cb)};
  for (int k = 0; k < 3; ++k) {
    if (rgb[k] < 0 || rgb[k] > 255)
      throw Error(classes.file.string(), "line " + std::to_string(classes.line_of_row[r]), "colour out of 0..255");
    c.rgb[k] = static_cast<std::uint8_t>(rgb[k]);
  }
  return c;
}

/// The checks the sequence reader makes of the classes it is given, here naming the rows: each index
/// (a label image's value) and each name once, and one Void row.
class DistinctClasses {
 public:
  explicit DistinctClasses(const CsvTable& table) : table_(table) {}

  void add(const ClassInfo& c, std::size_t row) {
    const int line = table_.line_of_row[row];
    const auto [by_index, new_index] = line_of_index_.emplace(c.file_value, line);
    if (!new_index)
      fail(line, "index", "is " + std::to_string(c.file_value) + ", as on line " + std::to_string(by_index->second) +
                              " (each class needs its own label value)");
    const bool is_void = lower_case(c.name) == "void";
    const auto [by_name, new_name] = line_of_name_.emplace(is_void ? std::string("void") : c.name, line);
    if (!new_name)
      fail(line, "name",
           is_void ? "a second Void row (line " + std::to_string(by_name->second) + " is the ignore label)"
                   : "\"" + c.name + "\" is also the name on line " + std::to_string(by_name->second));
  }

 private:
  [[noreturn]] void fail(int line, const char* column, const std::string& why) const {
    throw Error(table_.file.string(), "line " + std::to_string(line) + ", " + column, why);
  }
  const CsvTable& table_;
  std::map<int, int> line_of_index_;
  std::map<std::string, int> line_of_name_;
};

}  // namespace

CamvidClasses read_camvid_classes(const fs::path& file) {
  // index,name,r,g,b; the row named Void (any case) is the ignore label.
  const CsvTable classes = read_csv(file);
  CamvidClasses out;
  std::optional<ClassInfo> void_class;
  DistinctClasses distinct(classes);
  for (std::size_t r = 0; r < classes.rows.size(); ++r) {
    const ClassInfo c = parse_class_row(classes, r);
    distinct.add(c, r);
    if (lower_case(c.name) == "void") {
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

namespace {

/// The columns of frames.csv that the import reads.
struct FrameColumns {
  int sequence, frame, split, image, label;
  explicit FrameColumns(const CsvTable& t)
      : sequence(t.column("sequence")), frame(t.column("frame")), split(t.column("split")), image(t.column("image")),
        label(t.column("label")) {}
};

/// Error unless frames.csv has rows of every split asked for.
void require_splits(const CsvTable& frames, const FrameColumns& col, const std::set<std::string>& wanted) {
  std::set<std::string> seen_splits;
  for (const auto& row : frames.rows) seen_splits.insert(row[col.split]);
  for (const auto& s : wanted)
    if (!seen_splits.count(s)) {
      std::string have;
      for (const auto& x : seen_splits) have += (have.empty() ? "" : ", ") + x;
      throw Error(frames.file.string(), "split", "no frames of split \"" + s + "\" (it has: " + have + ")");
    }
}

/// Error when a video frame of a CamVid sequence is listed twice (in one split or in two): it would be
/// a frame of two runs, or trained on and tested on, and its time would not increase within a run.
void refuse_repeated_frames(const CsvTable& frames, const FrameColumns& col) {
  std::map<std::pair<std::string, long>, int> line_of_frame;
  for (std::size_t r = 0; r < frames.rows.size(); ++r) {
    const long frame = parse_in_range(frames, r, col.frame, 0, kMaxVideoFrame);
    const std::string& sequence = frames.rows[r][col.sequence];
    const auto [first, is_new] = line_of_frame.emplace(std::pair{sequence, frame}, frames.line_of_row[r]);
    if (!is_new)
      throw Error(frames.file.string(), "line " + std::to_string(frames.line_of_row[r]),
                  "frame " + std::to_string(frame) + " of sequence " + sequence + " is listed again (first on line " +
                      std::to_string(first->second) + ")");
  }
}

struct PendingRun {
  CamvidRun run;
  std::vector<std::size_t> rows;
  long last_frame = 0;
};

/// The wanted rows of frames.csv cut into runs: rows of one CamVid sequence and split, contiguous in
/// the file, at most max_gap video frames apart and at about the run's rate.
std::vector<PendingRun> group_runs(const CsvTable& frames, const FrameColumns& col, const std::set<std::string>& wanted,
                                   int max_gap) {
  std::vector<PendingRun> runs;
  for (std::size_t r = 0; r < frames.rows.size(); ++r) {
    const auto& row = frames.rows[r];
    if (!wanted.count(row[col.split])) continue;
    const long frame = parse_in_range(frames, r, col.frame, 0, kMaxVideoFrame);
    bool extend = false;
    if (!runs.empty()) {
      PendingRun& p = runs.back();
      const long gap = frame - p.last_frame;
      extend = p.run.camvid_sequence == row[col.sequence] && p.run.split == row[col.split] && gap > 0 &&
               gap <= max_gap && (p.run.frame_gap == 0 || (gap * 2 > p.run.frame_gap && gap < p.run.frame_gap * 2));
      // The rows of one split must be contiguous in frames.csv to be one run; a gap of another rate
      // (2 vs 30 video frames) starts a new run.
      if (extend && p.run.frame_gap == 0) p.run.frame_gap = static_cast<int>(gap);
    }
    if (!extend) {
      PendingRun p;
      p.run.camvid_sequence = row[col.sequence];
      p.run.split = row[col.split];
      runs.push_back(std::move(p));
    }
    runs.back().rows.push_back(r);
    runs.back().last_frame = frame;
  }
  if (runs.empty()) throw Error(frames.file.string(), "", "no frames for the splits asked for");
  return runs;
}

/// Where the import takes its inputs from and what it writes.
struct CamvidSource {
  fs::path root;
  const CsvTable& frames;
  FrameColumns col;
  CamvidClasses classes;
};

/// The sequence of one run (its frames, named where they lie), checked as the reader will check it.
Sequence run_sequence(PendingRun& p, const CamvidSource& src, const fs::path& out, const CamvidImportOptions& opt) {
  const CsvTable& frames = src.frames;
  const auto stem = [&](std::size_t r) { return fs::path(frames.rows[r][src.col.image]).stem().string(); };
  const std::string first = stem(p.rows.front()), last = stem(p.rows.back());
  const auto us = last.rfind('_');
  p.run.name = first + "-" + (us == std::string::npos ? last : last.substr(us + 1));
  p.run.frames = static_cast<int>(p.rows.size());
  p.run.folder = out / p.run.name;
  Sequence seq;
  seq.root = p.run.folder;
  seq.manifest = seq.root / kManifestName;
  seq.name = p.run.name;
  seq.kind = SequenceKind::Mono;
  seq.label_encoding = LabelEncoding::Index;
  seq.classes = src.classes.classes;
  seq.void_class = src.classes.void_class;
  seq.camera_height = opt.camera_height;
  const long frame0 = parse_in_range(frames, p.rows.front(), src.col.frame, 0, kMaxVideoFrame);
  for (std::size_t k = 0; k < p.rows.size(); ++k) {
    const std::size_t r = p.rows[k];
    const auto& row = frames.rows[r];
    FrameEntry e;
    e.left = src.root / row[src.col.image];
    e.label = src.root / row[src.col.label];
    const std::string where = "line " + std::to_string(frames.line_of_row[r]);
    if (const std::string why = why_not_a_file(e.left); !why.empty())
      throw Error(frames.file.string(), where, "image " + e.left.string() + " " + why);
    if (const std::string why = why_not_a_file(e.label); !why.empty())
      throw Error(frames.file.string(), where, "label " + e.label.string() + " " + why);
    e.time = double(parse_in_range(frames, r, src.col.frame, 0, kMaxVideoFrame) - frame0) / opt.video_fps;
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
  check_before_saving(seq);
  return seq;
}

}  // namespace

std::vector<CamvidRun> import_camvid(const fs::path& dir, const fs::path& out, const CamvidImportOptions& opt) {
  opt.validate();
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw Error(dir.string(), "", "no such folder");
  const fs::path root = fs::canonical(dir);
  CamvidClasses classes = read_camvid_classes(root / "classes.csv");
  const CsvTable frames = read_csv(root / "frames.csv");  // sequence,frame,split,image,label,gap...
  const CamvidSource src{root, frames, FrameColumns(frames), std::move(classes)};
  const std::set<std::string> wanted(opt.splits.begin(), opt.splits.end());
  require_splits(frames, src.col, wanted);
  refuse_repeated_frames(frames, src.col);
  std::vector<PendingRun> runs = group_runs(frames, src.col, wanted, opt.max_gap);

  // Every run is made and checked before any is written.
  std::vector<Sequence> sequences;
  std::map<std::string, std::size_t> run_of_name;
  for (auto& p : runs) {
    sequences.push_back(run_sequence(p, src, out, opt));
    if (const auto [other, is_new] = run_of_name.emplace(p.run.name, sequences.size() - 1); !is_new)
      throw Error(frames.file.string(), "line " + std::to_string(frames.line_of_row[p.rows.front()]),
                  "starts a run named " + p.run.name + " as the run from line " +
                      std::to_string(frames.line_of_row[runs[other->second].rows.front()]) + " is: both would be " +
                      p.run.folder.string());
  }
  std::vector<CamvidRun> result;
  Json index = {{"format", "smseg-camvid-import"}, {"version", 1}, {"source", root.string()},
                {"splits", opt.splits}, {"sequences", Json::array()}};
  for (std::size_t i = 0; i < runs.size(); ++i) {
    const CamvidRun& run = runs[i].run;
    save_sequence(sequences[i]);
    index["sequences"].push_back({{"name", run.name}, {"split", run.split}, {"frames", run.frames},
                                  {"frame_gap", run.frame_gap}, {"camvid_sequence", run.camvid_sequence},
                                  {"path", run.name + "/" + kManifestName}});
    result.push_back(run);
  }
  write_json_atomic(out / "index.json", index);
  return result;
}

}  // namespace smseg::sequence
