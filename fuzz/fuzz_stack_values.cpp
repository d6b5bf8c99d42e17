// Fuzzes the values file reader (stacks format version 2): FrameStack::open of a work folder whose
// frame file stacks/000000.values.bin is the input, as train-forest and eval-forest open each frame
// (decode every block, inflate, build the summed-area tables).
#include "fuzz_support.hpp"
#include "smseg/stacks/stack.hpp"

namespace {

/// A work folder of one labelled 4x3 frame with two features.
smseg::stacks::StackManifest work_folder() {
  smseg::stacks::StackManifest m;
  m.work = smseg::fuzz::temp_dir() / "work";
  m.size = cv::Size(4, 3);
  m.features = {"height", "depth"};
  m.classes = {"floor", "wall"};
  m.frames = {0};
  m.labelled_frames = {0};
  return m;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace smseg;
  static const stacks::StackManifest m = work_folder();
  fuzz::write_temp(stacks::values_path(m.work, 0).lexically_relative(fuzz::temp_dir()).string(),
                   fuzz::as_bytes(data, size));
  return fuzz::run_reader([&] { stacks::FrameStack::open(m, 0, true); });
}
