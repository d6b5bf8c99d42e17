// Fuzzes the tracks-and-poses reader (read_tracks on tracks.json, smseg-tracks), as extract-features
// --tracks and segment-cloud read a work folder's tracks.
#include "fuzz_support.hpp"
#include "smseg/stacks/front_ends.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace smseg;
  const auto file = fuzz::write_temp("tracks.json", fuzz::as_bytes(data, size));
  return fuzz::run_reader([&] { stacks::read_tracks(file); });
}
