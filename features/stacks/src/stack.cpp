#include "smseg/stacks/stack.hpp"

#include <fcntl.h>
#include <sys/mman.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <exception>
#include <limits>
#include <optional>

#include <tbb/parallel_for.h>

#include "frame_values.hpp"
#include "smseg/common/digest.hpp"
#include "smseg/stacks/label_check.hpp"

namespace smseg::stacks {

namespace {

std::string frame_stem(int frame) {
  char buf[16];
  std::snprintf(buf, sizeof buf, "%06d", frame);
  return buf;
}

std::string npy_bytes(const std::string& descr, const std::vector<std::size_t>& shape, const void* data,
                      std::size_t n) {
  std::string out = sequence::make_npy_header(descr, shape);
  out.append(static_cast<const char*>(data), n);
  return out;
}

/// A SAT built from finite feature values holds only finite sums; a NaN or infinity comes from a damaged
/// or foreign file and would silently turn every window that covers it into NaN (and so into the
/// right branch of every split), so it is refused with its place in the file.
void check_finite_sats(const fs::path& path, const double* sat, std::size_t features, std::size_t rows,
                       std::size_t cols) {
  const std::size_t n = features * rows * cols;
  for (std::size_t i = 0; i < n; ++i) {
    if (std::isfinite(sat[i])) continue;
    const std::size_t f = i / (rows * cols), y = i / cols % rows, x = i % cols;
    throw Error(path.string(), "",
                "SAT value " + std::to_string(i) + " (feature " + std::to_string(f) + ", row " + std::to_string(y) +
                    ", column " + std::to_string(x) + ") is " + (std::isnan(sat[i]) ? "NaN" : "infinite") +
                    "; the file is damaged (extract the frame again)");
  }
}

}  // namespace

fs::path values_path(const fs::path& work, int frame) {
  return work / "stacks" / (frame_stem(frame) + ".values.bin");
}
fs::path sat_path(const fs::path& work, int frame) { return work / "stacks" / (frame_stem(frame) + ".sat.npy"); }
fs::path gray_path(const fs::path& work, int frame) { return work / "stacks" / (frame_stem(frame) + ".gray.npy"); }
fs::path labels_path(const fs::path& work, int frame) {
  return work / "stacks" / (frame_stem(frame) + ".labels.npy");
}

bool StackManifest::has_frame(int f) const { return std::binary_search(frames.begin(), frames.end(), f); }
bool StackManifest::is_labelled(int f) const {
  return std::binary_search(labelled_frames.begin(), labelled_frames.end(), f);
}
fs::path StackManifest::labels_file(int f) const {
  if (base_manifest) return base_manifest->labels_file(f);
  return version == 1 ? labels_path(work, f) : values_path(work, f);
}

std::uintmax_t write_frame_values(const fs::path& work, int frame, cv::Size size, const std::vector<cv::Mat>& rasters,
                                  const cv::Mat& gray, const cv::Mat& labels, const std::vector<std::string>& names,
                                  const cv::Mat& colour) {
  const std::string bytes = values::encode(rasters, names, gray, labels, colour, size);
  write_file_atomic(values_path(work, frame), bytes);
  return bytes.size();
}

void write_frame_stack(const fs::path& work, int frame, const std::vector<cv::Mat>& sats, const cv::Mat& gray,
                       const cv::Mat& labels) {
  CV_Assert(!sats.empty() && gray.type() == CV_8UC1);
  const int H = gray.rows, W = gray.cols;
  std::string body;
  body.reserve(sats.size() * (H + 1) * (W + 1) * 8);
  for (const cv::Mat& s : sats) {
    CV_Assert(s.type() == CV_64FC1 && s.rows == H + 1 && s.cols == W + 1);
    const cv::Mat c = s.isContinuous() ? s : s.clone();
    body.append(reinterpret_cast<const char*>(c.data), c.total() * 8);
  }
  write_file_atomic(sat_path(work, frame),
                    sequence::make_npy_header("<f8", {sats.size(), std::size_t(H + 1), std::size_t(W + 1)}) + body);
  const cv::Mat g = gray.isContinuous() ? gray : gray.clone();
  write_file_atomic(gray_path(work, frame), npy_bytes("|u1", {std::size_t(H), std::size_t(W)}, g.data, g.total()));
  if (!labels.empty()) {
    CV_Assert(labels.type() == CV_8UC1 && labels.size() == gray.size());
    const cv::Mat l = labels.isContinuous() ? labels : labels.clone();
    write_file_atomic(labels_path(work, frame), npy_bytes("|u1", {std::size_t(H), std::size_t(W)}, l.data, l.total()));
  }
}

void save_stack_manifest(const StackManifest& m) {
  Json j = {{"format", kStacksFormat},
            {"version", m.version},
            {"sequence", m.sequence.string()},
            {"sequence_name", m.sequence_name},
            {"image_size", {{"width", m.size.width}, {"height", m.size.height}}},
            {"features", m.features},
            {"classes", m.classes},
            {"frames", m.frames},
            {"labelled_frames", m.labelled_frames},
            {"options", m.options}};
  if (m.version == 1)
    j["files"] = {{"sat", "stacks/NNNNNN.sat.npy (float64, F x (H+1) x (W+1))"},
                  {"gray", "stacks/NNNNNN.gray.npy (uint8, H x W)"},
                  {"labels", "stacks/NNNNNN.labels.npy (uint8, H x W, 255 = void)"}};
  else
    j["files"] = {{"values", "stacks/NNNNNN.values.bin (per channel: smallest exact type, zstd, or made from the "
                             "colour image; then gray, labels; summed-area tables built on reading; docs/formats.md)"}};
  if (m.base)
    j["base"] = {{"work", m.base->work.string()},
                 {"stacks_json_fnv1a64", m.base->stacks_json_fnv1a64},
                 {"features", m.base->features}};
  write_json_atomic(m.manifest_path(), j);
}

namespace {

/// A chain of bases longer than this is refused (a loop of folders naming each other).
constexpr int kMaxBaseDepth = 8;

StackManifest load_manifest(const fs::path& work, int depth);

std::vector<std::string> string_list(const JsonView& a) {
  std::vector<std::string> out;
  for (std::size_t i = 0; i < a.size(); ++i) out.push_back(a.at(i).as_str());
  if (out.empty()) a.fail("must not be empty");
  return out;
}

template <class T>
bool is_subset(const std::vector<T>& part, const std::vector<T>& whole) {
  return std::all_of(part.begin(), part.end(), [&](const T& x) { return std::find(whole.begin(), whole.end(), x) != whole.end(); });
}

/// The base a folder names: it must still be there, unchanged (its stacks.json's digest), and hold what
/// the folder reads from it.
void load_base(StackManifest& m, const JsonView& j, int depth) {
  const JsonView b = j.at("base");
  StackBase base{b.str("work"), b.str("stacks_json_fnv1a64"), string_list(b.at("features"))};
  const std::string again = "; run add-context again to write this folder";
  if (depth >= kMaxBaseDepth) b.fail("more than " + std::to_string(kMaxBaseDepth) + " work folders deep (a loop?)");
  std::error_code ec;
  if (!fs::is_regular_file(base.work / "stacks.json", ec))
    b.fail("names " + base.work.string() + ", which is no longer a work folder (moved or deleted?)" + again);
  if (fnv1a64_hex(read_file(base.work / "stacks.json")) != base.stacks_json_fnv1a64)
    b.fail("names " + base.work.string() + ", whose stacks.json has changed since this folder was written" + again);
  auto bm = std::make_shared<StackManifest>(load_manifest(base.work, depth + 1));
  if (!is_subset(base.features, bm->features)) b.fail("features are not all in " + bm->manifest_path().string());
  if (m.features.size() <= base.features.size() ||
      !std::equal(base.features.begin(), base.features.end(), m.features.begin()))
    j.fail("must start with base.features and add at least one", "features");
  if (bm->size != m.size || bm->classes != m.classes) j.fail("image size or classes differ from the base's", "base");
  if (!is_subset(m.frames, bm->frames) || !is_subset(m.labelled_frames, bm->labelled_frames))
    j.fail("names frames (or labelled frames) its base does not have", "frames");
  m.base = std::move(base);
  m.base_manifest = std::move(bm);
}

StackManifest load_manifest(const fs::path& work, int depth) {
  StackManifest m;
  m.work = work;
  std::error_code ec;
  if (!fs::exists(m.manifest_path(), ec)) {
    if (fs::is_directory(work, ec))
      throw Error(work.string(), "", "not a work folder: no stacks.json (run extract-features first)");
    throw Error(work.string(), "", "no such work folder");
  }
  const Json doc = read_json(m.manifest_path());
  const JsonView j(doc, m.manifest_path());
  check_format(j, kStacksFormat, {1, kStacksVersion});
  m.version = static_cast<int>(j.integer("version"));
  m.sequence = j.str("sequence");
  m.sequence_name = j.has("sequence_name") ? j.str("sequence_name") : std::string();
  const JsonView size = j.at("image_size");
  const auto w = size.integer("width"), h = size.integer("height");
  if (w <= 0 || h <= 0 || w > 20000 || h > 20000) size.fail("width and height must be in 1..20000 (as a sequence's)");
  m.size = cv::Size(static_cast<int>(w), static_cast<int>(h));
  m.features = string_list(j.at("features"));
  m.classes = string_list(j.at("classes"));
  const auto ints = [&](const char* key) {
    std::vector<int> out;
    const JsonView a = j.at(key);
    for (std::size_t i = 0; i < a.size(); ++i) {
      const auto v = a.at(i).as_integer();
      if (v < 0 || v > std::numeric_limits<int>::max() || (!out.empty() && v <= out.back()))
        a.at(i).fail("frames must be ascending, non-negative frame numbers (got " + std::to_string(v) + ")");
      out.push_back(static_cast<int>(v));
    }
    return out;
  };
  m.frames = ints("frames");
  m.labelled_frames = ints("labelled_frames");
  for (int f : m.labelled_frames)
    if (!m.has_frame(f)) j.fail("labelled frame " + std::to_string(f) + " has no stack", "labelled_frames");
  if (j.has("options")) m.options = j.at("options").json();
  if (j.has("base")) {
    if (m.version == 1) j.fail("a version 1 work folder has no base", "base");
    load_base(m, j, depth);
  }
  return m;
}

}  // namespace

StackManifest load_stack_manifest(const fs::path& work) { return load_manifest(work, 0); }

std::vector<int> frames_in_range(const StackManifest& m, const FrameRange& range) {
  std::vector<int> frames;
  for (int f : m.frames)
    if (range.contains(f)) frames.push_back(f);
  if (frames.empty()) throw Error(m.work.string(), "frames", "no frame with a feature stack in " + range.str());
  return frames;
}

StackManifest extending_manifest(const StackManifest& m, const fs::path& out, const std::vector<std::string>& keep,
                                 const std::vector<std::string>& added) {
  StackManifest e = m;
  e.work = out;
  e.version = kStacksVersion;
  e.base = StackBase{fs::absolute(m.work).lexically_normal(), fnv1a64_hex(read_file(m.manifest_path())), keep};
  e.base_manifest.reset();
  e.features = keep;
  e.features.insert(e.features.end(), added.begin(), added.end());
  e.frames.clear();
  e.labelled_frames.clear();
  return e;
}

// A read-only memory mapping of one .npy file, checked against the expected dtype and shape.
struct FrameStack::Mapping {
  void* base = MAP_FAILED;
  std::size_t length = 0;
  const char* data = nullptr;

  /// A writable mapping of `bytes` in an unlinked temporary file (TMPDIR): the tables built on
  /// reading live in the page cache, so that drop_pages frees their memory as it does a .npy file's.
  static std::unique_ptr<Mapping> scratch(std::size_t bytes) {
    const fs::path dir = fs::temp_directory_path();
    int fd = ::open(dir.c_str(), O_TMPFILE | O_RDWR | O_CLOEXEC, 0600);
    if (fd < 0) {  // a file system without O_TMPFILE: a named file, unlinked at once
      std::string name = (dir / "smseg-stack-XXXXXX").string();
      fd = ::mkstemp(name.data());
      if (fd >= 0) ::unlink(name.c_str());
    }
    if (fd < 0) throw Error(dir.string(), "", std::string("cannot hold a temporary file for stack tables: ") + std::strerror(errno));
    auto m = std::make_unique<Mapping>();
    m->length = std::max<std::size_t>(bytes, 1);
    const bool sized = ::ftruncate(fd, static_cast<off_t>(m->length)) == 0;
    const int err = errno;
    if (sized) m->base = ::mmap(nullptr, m->length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, 0);
    ::close(fd);
    if (!sized || m->base == MAP_FAILED)
      throw Error(dir.string(), "", "cannot map " + std::to_string(m->length >> 20) + " MiB of stack tables: " +
                                         std::strerror(sized ? errno : err));
    m->data = static_cast<const char*>(m->base);
    return m;
  }
  char* writable() const { return static_cast<char*>(base); }

  Mapping() = default;

  // The file is checked (kind, header, size against its shape) before it is mapped: a FIFO is refused
  // without waiting for a writer, and a file of the wrong size is named as such even where the process
  // could not map it.
  Mapping(const fs::path& path, const std::string& descr, const std::vector<std::size_t>& shape) {
    const int fd = ::open(path.c_str(), O_RDONLY | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) throw Error(path.string(), "", std::string("cannot be opened: ") + std::strerror(errno));
    try {
      length = checked_length(fd, path, descr, shape, data_offset);
    } catch (...) {
      ::close(fd);
      throw;
    }
    base = ::mmap(nullptr, length, PROT_READ, MAP_PRIVATE, fd, 0);
    const int err = errno;
    ::close(fd);
    if (base == MAP_FAILED)
      throw Error(path.string(), "",
                  "cannot be mapped (" + std::to_string(length >> 20) + " MiB): " + std::strerror(err) +
                      (err == ENOMEM ? " (the process's address-space limit, ulimit -v?)" : ""));
    data = static_cast<const char*>(base) + data_offset;
  }
  std::size_t data_offset = 0;

  /// The file's length, once it is a regular file whose header has this dtype and shape and whose size
  /// is the header's plus the data's; Error naming the file otherwise.
  static std::size_t checked_length(int fd, const fs::path& path, const std::string& descr,
                                    const std::vector<std::size_t>& shape, std::size_t& data_offset) {
    struct stat st {};
    if (::fstat(fd, &st) != 0) throw Error(path.string(), "", std::string("cannot be read: ") + std::strerror(errno));
    if (S_ISDIR(st.st_mode)) throw Error(path.string(), "", "is a folder, expected a .npy file");
    if (!S_ISREG(st.st_mode)) {
      const std::string why = why_not_a_file(path);
      throw Error(path.string(), "", why.empty() ? "is not a regular file" : why);
    }
    if (st.st_size <= 0) throw Error(path.string(), "", "is empty");
    const auto length = static_cast<std::size_t>(st.st_size);
    std::string head(std::min<std::size_t>(length, 65536 + 12), '\0');
    const ssize_t got = ::pread(fd, head.data(), head.size(), 0);
    if (got < 0) throw Error(path.string(), "", std::string("cannot be read: ") + std::strerror(errno));
    head.resize(static_cast<std::size_t>(got));
    const sequence::NpyHeader h = sequence::parse_npy_header(head, path);
    if (h.descr != descr) throw Error(path.string(), "descr", "is '" + h.descr + "', expected '" + descr + "'");
    if (h.shape != shape) {
      std::string have, want;
      for (auto s : h.shape) have += (have.empty() ? "" : "x") + std::to_string(s);
      for (auto s : shape) want += (want.empty() ? "" : "x") + std::to_string(s);
      throw Error(path.string(), "shape", "is " + have + ", the work folder's stacks.json says " + want);
    }
    std::size_t n = descr == "<f8" ? 8 : 1;
    for (auto s : shape) n *= s;
    if (length != h.data_offset + n) throw Error(path.string(), "", "size does not match its shape (truncated?)");
    if (h.data_offset % 8 != 0) throw Error(path.string(), "", "data is not 8-byte aligned");
    data_offset = h.data_offset;
    return length;
  }
  ~Mapping() {
    if (base != MAP_FAILED) ::munmap(base, length);
  }
  /// Drops the resident pages (a read-only file mapping: they come back from the file on the next read).
  void drop_pages() const {
    if (base != MAP_FAILED) ::madvise(base, length, MADV_DONTNEED);
  }
};

FrameStack::FrameStack(FrameStack&&) noexcept = default;
FrameStack& FrameStack::operator=(FrameStack&&) noexcept = default;
FrameStack::~FrameStack() = default;

FrameStack FrameStack::open(const StackManifest& m, int frame, bool with_labels, const std::vector<bool>& wanted) {
  CV_Assert(wanted.empty() || wanted.size() == m.features.size());
  if (!m.has_frame(frame))
    throw Error(m.manifest_path().string(), "frames", "frame " + std::to_string(frame) + " has no feature stack");
  if (with_labels && !m.is_labelled(frame))
    throw Error(m.manifest_path().string(), "labelled_frames", "frame " + std::to_string(frame) + " is not labelled");
  FrameStack s;
  s.frame_ = frame;
  s.size_ = m.size;
  if (m.version != 1) {
    s.open_values(m, frame, with_labels, wanted);
    return s;
  }
  const std::size_t H = m.size.height, W = m.size.width;
  auto sat = std::make_unique<Mapping>(sat_path(m.work, frame), "<f8", std::vector<std::size_t>{m.features.size(), H + 1, W + 1});
  check_finite_sats(sat_path(m.work, frame), reinterpret_cast<const double*>(sat->data), m.features.size(), H + 1,
                    W + 1);
  sat->drop_pages();  // the check read every page; training and evaluation map back what they use
  for (std::size_t f = 0; f < m.features.size(); ++f)
    s.sats_.push_back(reinterpret_cast<const double*>(sat->data) + f * (H + 1) * (W + 1));
  s.mappings_.push_back(std::move(sat));
  s.mappings_.push_back(std::make_unique<Mapping>(gray_path(m.work, frame), "|u1", std::vector<std::size_t>{H, W}));
  s.gray_ = reinterpret_cast<const std::uint8_t*>(s.mappings_.back()->data);
  if (with_labels) {
    s.mappings_.push_back(std::make_unique<Mapping>(labels_path(m.work, frame), "|u1", std::vector<std::size_t>{H, W}));
    s.labels_ = reinterpret_cast<const std::uint8_t*>(s.mappings_.back()->data);
  }
  return s;
}

// Version 2: the base's tables and images first (if any), then this folder's own channels, decoded
// into one scratch mapping: the wanted tables, then greyscale, then labels.
void FrameStack::open_values(const StackManifest& m, int frame, bool with_labels, const std::vector<bool>& wanted) {
  const auto is_wanted = [&](std::size_t f) { return wanted.empty() || wanted[f]; };
  if (m.base_manifest) {
    const auto& bf = m.base_manifest->features;
    std::vector<bool> base_wanted(bf.size(), false);
    std::vector<std::size_t> in_base;  // per base feature this folder reads: its index in the base
    for (std::size_t f = 0; f < m.base->features.size(); ++f) {
      in_base.push_back(static_cast<std::size_t>(std::find(bf.begin(), bf.end(), m.base->features[f]) - bf.begin()));
      if (is_wanted(f)) base_wanted[in_base.back()] = true;
    }
    FrameStack base = open(*m.base_manifest, frame, with_labels, base_wanted);
    for (std::size_t i : in_base) sats_.push_back(base.sat(static_cast<int>(i)));
    gray_ = base.gray_;
    labels_ = base.labels_;
    for (auto& mapping : base.mappings_) mappings_.push_back(std::move(mapping));
  }
  values::Expected ex;
  ex.size = m.size;
  ex.channels = m.own_features();
  ex.names.assign(m.features.end() - static_cast<std::ptrdiff_t>(ex.channels), m.features.end());
  if (!m.base_manifest) ex.images = values::kGrayImage | (m.is_labelled(frame) ? values::kLabelsImage : 0u);
  const std::size_t first_own = m.features.size() - ex.channels;
  std::size_t tables = 0;
  for (std::size_t k = 0; k < ex.channels; ++k) tables += is_wanted(first_own + k) ? 1 : 0;
  const std::size_t H = m.size.height, W = m.size.width, table = (H + 1) * (W + 1) * sizeof(double);
  const std::size_t images = ((ex.images & values::kGrayImage) ? H * W : 0) + ((ex.images & values::kLabelsImage) ? H * W : 0);
  const fs::path file = values_path(m.work, frame);
  const std::string bytes = read_file(file, values::max_file_bytes(ex));
  auto scratch = Mapping::scratch(tables * table + images);
  values::Output out;
  std::size_t next = 0;
  for (std::size_t k = 0; k < ex.channels; ++k)
    out.sats.push_back(is_wanted(first_own + k) ? reinterpret_cast<double*>(scratch->writable() + next++ * table) : nullptr);
  if (ex.images & values::kGrayImage) out.gray = reinterpret_cast<std::uint8_t*>(scratch->writable() + tables * table);
  if (ex.images & values::kLabelsImage) out.labels = out.gray + H * W;
  values::decode(bytes, file, ex, out);
  sats_.insert(sats_.end(), out.sats.begin(), out.sats.end());
  if (!m.base_manifest) {
    gray_ = out.gray;
    labels_ = with_labels ? out.labels : nullptr;
  }
  scratch->drop_pages();  // written back to the temporary file; read again when touched
  mappings_.push_back(std::move(scratch));
}

const double* FrameStack::sat(int feature) const { return sats_[static_cast<std::size_t>(feature)]; }
const std::uint8_t* FrameStack::gray() const { return gray_; }
const std::uint8_t* FrameStack::labels() const { return labels_; }

forest::FrameData FrameStack::view() const {
  forest::FrameData d;
  d.width = size_.width;
  d.height = size_.height;
  d.sats = sats_;
  d.gray = gray_;
  d.labels = labels_;
  // The mappings live on the heap, so the pointers survive moves of this FrameStack.
  std::vector<const Mapping*> mappings;
  for (const auto& m : mappings_) mappings.push_back(m.get());
  d.release = [mappings] {
    for (const Mapping* m : mappings) m->drop_pages();
  };
  return d;
}

FrameStack FrameStack::mirror_of(const forest::FrameData& frame, const std::vector<ChannelMirror>& plan,
                                 int frame_number) {
  CV_Assert(plan.size() == frame.sats.size() && frame.gray);
  const std::size_t H = static_cast<std::size_t>(frame.height), W = static_cast<std::size_t>(frame.width);
  const std::size_t table = (H + 1) * (W + 1) * sizeof(double);
  FrameStack s;
  s.frame_ = frame_number;
  s.size_ = cv::Size(frame.width, frame.height);
  auto scratch = Mapping::scratch(plan.size() * table + (frame.labels ? 2 : 1) * H * W);
  char* next = scratch->writable();
  for (const ChannelMirror& c : plan) {
    auto* out = reinterpret_cast<double*>(next);
    const double* source = frame.sats[c.source];
    if (c.flip)
      mirror_table(source, frame.width, frame.height, c.negate, out);
    else
      std::copy(source, source + table / sizeof(double), out);
    s.sats_.push_back(out);
    next += table;
  }
  auto* gray = reinterpret_cast<std::uint8_t*>(next);
  mirror_image(frame.gray, frame.width, frame.height, gray);
  s.gray_ = gray;
  if (frame.labels) {
    auto* labels = gray + H * W;
    mirror_image(frame.labels, frame.width, frame.height, labels);
    s.labels_ = labels;
  }
  scratch->drop_pages();
  s.mappings_.push_back(std::move(scratch));
  return s;
}

FrameStack FrameStack::exposed_copy(const forest::FrameData& frame, const std::vector<ChannelExposure>& plan, double k,
                                    int frame_number) {
  CV_Assert(plan.size() == frame.sats.size());
  const std::size_t H = static_cast<std::size_t>(frame.height), W = static_cast<std::size_t>(frame.width);
  const std::size_t table = (H + 1) * (W + 1) * sizeof(double);
  const auto changed = static_cast<std::size_t>(
      std::count_if(plan.begin(), plan.end(), [](const ChannelExposure& e) { return !e.unchanged(); }));
  FrameStack s;
  s.frame_ = frame_number;
  s.size_ = cv::Size(frame.width, frame.height);
  // + 1: a mapping is never empty, even for a frame whose light changes nothing it holds.
  auto scratch = Mapping::scratch(changed * table + (frame.gray ? H * W : 0) + 1);
  char* next = scratch->writable();
  for (std::size_t c = 0; c < plan.size(); ++c) {
    if (plan[c].unchanged()) {  // the frame's own table: no copy of what the light does not change
      s.sats_.push_back(frame.sats[c]);
      continue;
    }
    auto* out = reinterpret_cast<double*>(next);
    exposed_table(frame.sats[c], frame.width, frame.height, plan[c], out);
    s.sats_.push_back(out);
    next += table;
  }
  if (frame.gray) {
    auto* gray = reinterpret_cast<std::uint8_t*>(next);
    exposed_gray(frame.gray, frame.width, frame.height, k, gray);
    s.gray_ = gray;
  }
  s.labels_ = frame.labels;
  scratch->drop_pages();
  s.mappings_.push_back(std::move(scratch));
  return s;
}

FrameRange FrameRange::parse(const std::string& text, const std::string& option) {
  FrameRange r;
  const auto colon = text.find(':');
  const auto num = [&](const std::string& s, int fallback) {
    if (s.empty()) return fallback;
    try {
      std::size_t used = 0;
      const long v = std::stol(s, &used);
      if (used == s.size() && v >= 0 && v < std::numeric_limits<int>::max()) return static_cast<int>(v);
    } catch (const std::exception&) {
    }
    throw Error("", option, "\"" + text + "\" is not a frame range (A:B, A:, :B or A; frames >= 0)");
  };
  if (colon == std::string::npos) {
    if (text.empty()) throw Error("", option, "empty frame range");
    r.begin = num(text, 0);
    r.end = r.begin + 1;
  } else {
    r.begin = num(text.substr(0, colon), 0);
    r.end = num(text.substr(colon + 1), std::numeric_limits<int>::max());
  }
  if (r.end <= r.begin) throw Error("", option, "\"" + text + "\" is an empty range");
  return r;
}

std::string FrameRange::str() const {
  return std::to_string(begin) + ":" + (end == std::numeric_limits<int>::max() ? std::string() : std::to_string(end));
}

void check_labels(const forest::FrameData& frame, const fs::path& file, std::size_t classes) {
  const std::size_t n = static_cast<std::size_t>(frame.width) * frame.height;
  for (std::size_t p = 0; p < n; ++p) {
    const std::uint8_t l = frame.labels[p];
    if (l != forest::kVoidLabel && l >= classes)
      throw Error(file.string(), "",
                  "pixel (" + std::to_string(p % frame.width) + ", " + std::to_string(p / frame.width) + ") has label " +
                      std::to_string(l) + ", but the work folder has " + std::to_string(classes) +
                      " classes (255 = void)");
  }
}

namespace {

// The frames (folder, frame) of `manifests`, each with the features of its folder's `feature_index` only,
// opened in parallel (each decodes and sums its own file). The error of the first frame that fails, in
// frame order, whatever the thread count.
std::vector<FrameStack> open_frames(const std::vector<StackManifest>& manifests,
                                    const std::vector<std::pair<int, int>>& frames,
                                    const std::vector<std::vector<int>>& feature_index, bool with_labels) {
  std::vector<std::vector<bool>> wanted;
  for (std::size_t k = 0; k < manifests.size(); ++k) {
    wanted.emplace_back(manifests[k].features.size(), false);
    for (int i : feature_index[k]) wanted.back()[static_cast<std::size_t>(i)] = true;
  }
  std::vector<std::optional<FrameStack>> opened(frames.size());
  std::vector<std::exception_ptr> errors(frames.size());
  tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t i) {
    const auto [k, f] = frames[i];
    try {
      opened[i].emplace(FrameStack::open(manifests[static_cast<std::size_t>(k)], f, with_labels,
                                         wanted[static_cast<std::size_t>(k)]));
    } catch (...) {
      errors[i] = std::current_exception();
    }
  });
  std::vector<FrameStack> stacks;
  for (std::size_t i = 0; i < frames.size(); ++i) {
    if (errors[i]) std::rethrow_exception(errors[i]);
    stacks.push_back(std::move(*opened[i]));
  }
  return stacks;
}

}  // namespace

StackSet open_stacks(const std::vector<fs::path>& works, const FrameRange& range, bool labelled_only,
                     bool with_labels, const std::vector<std::string>& features) {
  if (works.empty()) throw Error("", "WORK", "name at least one work folder");
  StackSet set;
  std::vector<std::vector<int>> feature_index;
  for (const auto& w : works) {
    StackManifest m = load_stack_manifest(w);
    if (!set.manifests.empty()) {
      const StackManifest& first = set.manifests.front();
      if (m.size != first.size)
        throw Error(m.manifest_path().string(), "image_size",
                    "differs from " + first.manifest_path().string() + " (all work folders must share one size)");
      if (m.classes != first.classes)
        throw Error(m.manifest_path().string(), "classes", "differ from those of " + first.manifest_path().string());
    }
    std::vector<int> idx;
    const auto& wanted = features.empty() ? m.features : features;
    for (const auto& name : wanted) {
      auto it = std::find(m.features.begin(), m.features.end(), name);
      if (it == m.features.end()) {
        std::string have;
        for (const auto& f : m.features) have += (have.empty() ? "" : ",") + f;
        throw Error(m.manifest_path().string(), "features", "has no feature \"" + name + "\" (it has " + have + ")");
      }
      idx.push_back(static_cast<int>(it - m.features.begin()));
    }
    feature_index.push_back(idx);
    set.manifests.push_back(std::move(m));
  }
  set.dataset.width = set.manifests.front().size.width;
  set.dataset.height = set.manifests.front().size.height;
  set.dataset.classes = set.manifests.front().classes;
  for (int i : feature_index.front()) set.dataset.features.push_back(set.manifests.front().features[i]);
  for (std::size_t k = 0; k < set.manifests.size(); ++k) {
    const StackManifest& m = set.manifests[k];
    for (int f : labelled_only ? m.labelled_frames : m.frames)
      if (range.contains(f)) set.origin.emplace_back(static_cast<int>(k), f);
  }
  if (set.origin.empty())
    throw Error(works.front().string(), "frames",
                std::string("no ") + (labelled_only ? "labelled " : "") + "frame with a feature stack in " + range.str());
  set.stacks = open_frames(set.manifests, set.origin, feature_index, with_labels);
  for (std::size_t i = 0; i < set.stacks.size(); ++i) {
    const forest::FrameData full = set.stacks[i].view();
    forest::FrameData d = full;
    d.sats.clear();
    for (int fi : feature_index[set.origin[i].first]) d.sats.push_back(full.sats[fi]);
    if (d.labels)
      check_labels(d, set.manifests[set.origin[i].first].labels_file(set.origin[i].second),
                   set.dataset.classes.size());
    set.dataset.frames.push_back(d);
  }
  return set;
}

namespace {

bool holds_points(const forest::FrameData& frame) {
  const std::size_t total = static_cast<std::size_t>(frame.height) * (frame.width + 1) + frame.width;
  for (const double* sat : frame.sats)
    if (sat[total] != 0.0) return true;
  return false;
}

}  // namespace

std::vector<std::pair<int, int>> frames_without_points(const StackSet& set) {
  std::vector<std::pair<int, int>> empty;
  for (std::size_t i = 0; i < set.origin.size(); ++i)  // the frames read (a mirror holds what its frame holds)
    if (!holds_points(set.dataset.frames[i])) empty.push_back(set.origin[i]);
  return empty;
}

std::string frames_without_points_message(const StackSet& set, const std::vector<std::pair<int, int>>& empty) {
  constexpr int kNamedFrames = 5;
  std::string text;
  for (std::size_t w = 0; w < set.manifests.size(); ++w) {
    int in_folder = 0, selected = 0;
    std::string named;
    for (const auto& o : set.origin) selected += o.first == static_cast<int>(w);
    for (const auto& [work, frame] : empty) {
      if (work != static_cast<int>(w)) continue;
      if (++in_folder <= kNamedFrames) named += (named.empty() ? "" : ", ") + std::to_string(frame);
    }
    if (in_folder == 0) continue;
    if (in_folder > kNamedFrames) named += ", ...";
    text += (text.empty() ? "" : "; ") + set.manifests[w].work.string() + ": " + std::to_string(in_folder) + " of " +
            std::to_string(selected) + " frames hold no tracked point (" + named + ")";
  }
  return text;
}

namespace {

/// make(i, frame i) for the set's first n frames, in parallel, each frame released once read (training
/// reads it again later); the first error is thrown once all are done.
template <class Make>
std::vector<FrameStack> frames_made_in_parallel(const StackSet& set, std::size_t n, Make&& make) {
  std::vector<std::optional<FrameStack>> made(n);
  std::vector<std::exception_ptr> errors(n);
  tbb::parallel_for(std::size_t{0}, n, [&](std::size_t i) {
    try {
      const forest::FrameData& frame = set.dataset.frames[i];
      made[i].emplace(make(i, frame));
      if (frame.release) frame.release();
    } catch (...) {
      errors[i] = std::current_exception();
    }
  });
  for (const std::exception_ptr& e : errors)
    if (e) std::rethrow_exception(e);
  std::vector<FrameStack> out;
  out.reserve(n);
  for (auto& m : made) out.push_back(std::move(*m));
  return out;
}

/// The frame number of the set's i-th frame (a mirror's is its frame's).
int frame_number(const StackSet& set, std::size_t i) { return set.origin[i % set.origin.size()].second; }

/// The view of `copy`, made from `frame` and sharing some of its tables: its release drops both.
forest::FrameData view_sharing(const FrameStack& copy, const forest::FrameData& frame) {
  forest::FrameData view = copy.view();
  view.release = [own = view.release, shared = frame.release] {
    own();
    if (shared) shared();
  };
  return view;
}

}  // namespace

void add_mirrored_frames(StackSet& set) {
  CV_Assert(!set.mirror && set.exposures.empty());
  const auto plan = mirror_plan(set.dataset.features, set.manifests.front().manifest_path().string());
  std::vector<FrameStack> mirrors =
      frames_made_in_parallel(set, set.dataset.frames.size(), [&](std::size_t i, const forest::FrameData& frame) {
        return FrameStack::mirror_of(frame, plan, frame_number(set, i));
      });
  for (FrameStack& m : mirrors) {
    set.stacks.push_back(std::move(m));
    set.dataset.frames.push_back(set.stacks.back().view());
  }
  set.mirror = true;
}

void add_exposed_frames(StackSet& set, const std::vector<double>& exposures) {
  CV_Assert(set.exposures.empty());
  const std::string source = set.manifests.front().manifest_path().string();
  check_exposures(exposures, "--exposures");
  const std::size_t n = set.dataset.frames.size();  // the frames read and their mirrors
  for (double k : exposures) {
    const auto plan = exposure_plan(set.dataset.features, k, source);
    std::vector<FrameStack> copies = frames_made_in_parallel(set, n, [&](std::size_t i, const forest::FrameData& frame) {
      return FrameStack::exposed_copy(frame, plan, k, frame_number(set, i));
    });
    for (std::size_t i = 0; i < n; ++i) {
      set.stacks.push_back(std::move(copies[i]));
      set.dataset.frames.push_back(view_sharing(set.stacks.back(), set.dataset.frames[i]));
    }
  }
  set.exposures = exposures;
}

Json training_data_record(const StackSet& set) {
  Json works = Json::array();
  for (std::size_t w = 0; w < set.manifests.size(); ++w) {
    const StackManifest& m = set.manifests[w];
    Json frames = Json::array();
    for (const auto& [work, frame] : set.origin)
      if (work == static_cast<int>(w)) frames.push_back(frame);
    std::error_code ec;
    const fs::path path = fs::weakly_canonical(m.work, ec);
    works.push_back({{"path", (ec ? m.work : path).string()},
                     {"stacks_json_fnv1a64", fnv1a64_hex(read_file(m.manifest_path()))},
                     {"frames", frames}});
  }
  Json record = {{"works", works}, {"features", set.dataset.features}};
  if (set.mirrored()) record["mirrored"] = true;  // only then: records of earlier parts stay as they were
  if (!set.exposures.empty()) record["exposures"] = set.exposures;  // likewise
  return record;
}

FrameStack lighten_frame(forest::FrameData& frame, const std::vector<std::string>& features, double target,
                         int frame_number, const std::string& source) {
  const auto l = std::find(features.begin(), features.end(), "fL");
  if (l == features.end()) lightness_plan(features, 0.0, target, source);  // throws: no fL to measure
  const double* table = frame.sats[static_cast<std::size_t>(l - features.begin())];
  const std::size_t last = static_cast<std::size_t>(frame.height) * (frame.width + 1) + frame.width;
  const double mean = table[last] / (double(frame.width) * double(frame.height));
  FrameStack copy = FrameStack::exposed_copy(frame, lightness_plan(features, mean, target, source),
                                             lightness_exposure(mean, target), frame_number);
  frame = view_sharing(copy, frame);
  return copy;
}

void lighten_frames(StackSet& set, double target) {
  if (target == 0.0) return;
  CV_Assert(set.lightened.empty());
  const std::string source = set.manifests.front().manifest_path().string();
  std::vector<forest::FrameData> frames = set.dataset.frames;
  set.lightened = frames_made_in_parallel(set, frames.size(), [&](std::size_t i, const forest::FrameData&) {
    return lighten_frame(frames[i], set.dataset.features, target, frame_number(set, i), source);
  });
  set.dataset.frames = std::move(frames);
}

}  // namespace smseg::stacks
