// Fuzzes the label image reader: Sequence::load_labels decodes a label image (PNG, or whatever
// OpenCV recognises) and maps its values (index encoding) or colours (rgb encoding) to classes with
// the sequence's class table, CamVid's. Input: byte 0 picks the encoding (even: index, odd: rgb),
// bytes 1 and 2 the image size the manifest promises (1..64 each), the rest is the image file.
#include "fuzz_support.hpp"
#include "smseg/sequence/sequence.hpp"

namespace {

smseg::sequence::Sequence camvid_like_sequence(bool rgb, int width, int height) {
  using namespace smseg::sequence;
  Sequence seq;
  seq.root = smseg::fuzz::temp_dir();
  seq.manifest = seq.root / kManifestName;
  seq.size = cv::Size(width, height);
  seq.label_encoding = rgb ? LabelEncoding::Rgb : LabelEncoding::Index;
  const std::vector<std::pair<std::string, std::array<std::uint8_t, 3>>> camvid = {
      {"Sky", {128, 128, 128}},  {"Building", {128, 0, 0}},   {"Pole", {192, 192, 128}},
      {"Road", {128, 64, 128}},  {"Pavement", {60, 40, 222}},   {"Tree", {128, 128, 0}},
      {"SignSymbol", {192, 128, 128}}, {"Fence", {64, 64, 128}}, {"Car", {64, 0, 128}},
      {"Pedestrian", {64, 64, 0}}, {"Bicyclist", {0, 128, 192}}};
  for (std::size_t i = 0; i < camvid.size(); ++i)
    seq.classes.push_back(ClassInfo{camvid[i].first, static_cast<int>(i), camvid[i].second});
  seq.void_class = ClassInfo{"Void", 11, {0, 0, 0}};
  FrameEntry frame;
  frame.left = "left.png";
  frame.label = "label.png";
  seq.frames.push_back(frame);
  seq.labelled_frames = {0};
  return seq;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace smseg;
  if (size < 3) return 0;
  const sequence::Sequence seq = camvid_like_sequence(data[0] % 2 == 1, 1 + data[1] % 64, 1 + data[2] % 64);
  fuzz::write_temp("label.png", fuzz::as_bytes(data + 3, size - 3));
  return fuzz::run_reader([&] { seq.load_labels(0); });
}
