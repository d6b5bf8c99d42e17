// Fuzzes CamVid's class table reader (read_camvid_classes on classes.csv), as import-camvid and
// --classes read it.
#include "fuzz_support.hpp"
#include "smseg/sequence/camvid.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace smseg;
  const auto file = fuzz::write_temp("classes.csv", fuzz::as_bytes(data, size));
  return fuzz::run_reader([&] { sequence::read_camvid_classes(file); });
}
