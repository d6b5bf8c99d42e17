// Fuzzes the .npy readers: read_npy_f32 (a sequence's float disparity and ground-truth depth) and the
// memory-mapped stack files of version 1 work folders, FrameStack::open of a work folder whose SAT file (float64,
// F x (H+1) x (W+1)) is the input, as train-forest and eval-forest open each frame.
#include "fuzz_support.hpp"
#include "smseg/sequence/npy.hpp"
#include "smseg/stacks/stack.hpp"

namespace {

/// A work folder of one 4x3 frame with two features, whose grey image file is valid.
const smseg::stacks::StackManifest& work_folder() {
  static const smseg::stacks::StackManifest manifest = [] {
    using namespace smseg::sequence;
    using namespace smseg::stacks;
    StackManifest m;
    m.work = smseg::fuzz::temp_dir() / "work";
    m.size = cv::Size(4, 3);
    m.features = {"height", "depth"};
    m.classes = {"floor", "wall"};
    m.frames = {0};
    m.version = 1;
    const std::string gray = make_npy_header("|u1", {3, 4}) + std::string(12, '\x7f');
    smseg::fuzz::write_temp(gray_path(m.work, 0).lexically_relative(smseg::fuzz::temp_dir()).string(), gray);
    return m;
  }();
  return manifest;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace smseg;
  const auto bytes = fuzz::as_bytes(data, size);
  const auto depth = fuzz::write_temp("depth.npy", bytes);
  fuzz::run_reader([&] { sequence::read_npy_f32(depth); });
  const stacks::StackManifest& m = work_folder();
  fuzz::write_temp(stacks::sat_path(m.work, 0).lexically_relative(fuzz::temp_dir()).string(), bytes);
  return fuzz::run_reader([&] { stacks::FrameStack::open(m, 0, false); });
}
