// Fuzzes the sequence manifest reader (load_sequence on sequence.json, docs/design.md 3.1), as check-sequence,
// extract-features and every tool that takes a sequence folder call it.
#include "fuzz_support.hpp"
#include "smseg/sequence/sequence.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace smseg;
  const auto manifest = fuzz::write_temp("sequence/sequence.json", fuzz::as_bytes(data, size));
  return fuzz::run_reader([&] { sequence::load_sequence(manifest.parent_path()); });
}
