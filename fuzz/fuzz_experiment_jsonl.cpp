// Fuzzes the resume reader of run-experiment (read_done_points on OUT/experiment.jsonl: JSON Lines,
// a half-written last line cut off, a point recorded twice refused).
#include "fuzz_support.hpp"
#include "smseg/experiments/runner.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace smseg;
  const auto file = fuzz::write_temp("out/experiment.jsonl", fuzz::as_bytes(data, size));
  return fuzz::run_reader([&] { experiments::read_done_points(file); });
}
