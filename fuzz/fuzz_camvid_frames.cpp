// Fuzzes import-camvid's frame list reader (import_camvid on a folder whose frames.csv is the input,
// with a real classes.csv and two real frames of a tiny image), writing into a temporary folder.
#include <opencv2/imgcodecs.hpp>

#include "fuzz_support.hpp"
#include "smseg/sequence/camvid.hpp"

namespace {

/// The folder: CamVid's real classes.csv lines and two 4x3 frames with their label images.
const smseg::fs::path& camvid_dir() {
  static const smseg::fs::path dir = [] {
    using namespace smseg;
    const fs::path d = fuzz::temp_dir() / "camvid";
    fuzz::write_temp("camvid/classes.csv",
                     "index,name,r,g,b\n0,Sky,128,128,128\n1,Building,128,0,0\n3,Road,128,64,128\n11,Void,0,0,0\n");
    fs::create_directories(d / "train");
    fs::create_directories(d / "trainannot");
    const cv::Mat image(3, 4, CV_8UC3, cv::Scalar(10, 20, 30)), label(3, 4, CV_8UC1, cv::Scalar(1));
    for (const char* name : {"0001TP_006690.png", "0001TP_006720.png"}) {
      cv::imwrite((d / "train" / name).string(), image);
      cv::imwrite((d / "trainannot" / name).string(), label);
    }
    return d;
  }();
  return dir;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace smseg;
  const fs::path dir = camvid_dir();
  fuzz::write_temp("camvid/frames.csv", fuzz::as_bytes(data, size));
  sequence::CamvidImportOptions options;
  options.splits = {"train"};
  return fuzz::run_reader([&] { sequence::import_camvid(dir, fuzz::temp_dir() / "imported", options); });
}
