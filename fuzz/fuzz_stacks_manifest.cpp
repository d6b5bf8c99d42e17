// Fuzzes the work folder's stack manifest reader (load_stack_manifest on stacks.json), as
// train-forest, eval-forest and run-experiment read a work folder.
#include "fuzz_support.hpp"
#include "smseg/stacks/stack.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace smseg;
  const auto manifest = fuzz::write_temp("work/stacks.json", fuzz::as_bytes(data, size));
  return fuzz::run_reader([&] { stacks::load_stack_manifest(manifest.parent_path()); });
}
