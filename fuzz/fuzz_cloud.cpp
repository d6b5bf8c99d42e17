// Fuzzes segment-cloud's point cloud reader (read_coloured_cloud: our own PCD and PLY reader, header,
// data of every kind, the x/y/z, colour and label fields). Byte 0 picks the extension (even: .pcd, odd:
// .ply), the rest is the file.
#include "fuzz_support.hpp"
#include "smseg/cloud/cloud_segment.hpp"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace smseg;
  if (size < 1) return 0;
  const auto file = fuzz::write_temp(data[0] % 2 == 0 ? "cloud.pcd" : "cloud.ply", fuzz::as_bytes(data + 1, size - 1));
  return fuzz::run_reader([&] { cloud::read_coloured_cloud(file); });
}
