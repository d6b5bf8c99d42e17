// Fuzzes the forest readers: load_forest (smseg-forest, the only version this build reads; other
// versions and foreign formats must be refused) and load_forest_part (smseg-forest-part, whose
// "forest" member is read by the same code), as eval-forest and train-forest --merge call them.
#include "fuzz_support.hpp"
#include "smseg/forest/forest.hpp"
#include "smseg/forest/parts.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace smseg;
  const auto file = fuzz::write_temp("forest.json", fuzz::as_bytes(data, size));
  fuzz::run_reader([&] { forest::load_forest(file); });
  return fuzz::run_reader([&] { forest::load_forest_part(file); });
}
