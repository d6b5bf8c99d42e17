// Fuzzes run-experiment's config reader (load_experiment), with and without --quick.
#include "fuzz_support.hpp"
#include "smseg/experiments/config.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace smseg;
  const auto file = fuzz::write_temp("experiment.json", fuzz::as_bytes(data, size));
  fuzz::run_reader([&] { experiments::load_experiment(file, false); });
  return fuzz::run_reader([&] { experiments::load_experiment(file, true); });
}
