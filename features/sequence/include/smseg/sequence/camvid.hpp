#pragma once
// CamVid adapter: turns a folder laid out like ../shared/data/camvid (frames.csv, classes.csv, image and
// label folders) into mono sequences of our format, one per contiguous run of a CamVid sequence inside
// one split, referring to the images where they are (no copies).

#include <string>
#include <vector>

#include "smseg/sequence/sequence.hpp"

namespace smseg::sequence {

struct CamvidImportOptions {
  std::vector<std::string> splits{"train", "val"};  ///< split names as written in frames.csv
  double video_fps = 30.0;           ///< CamVid frame numbers count 30 Hz video frames
  double camera_height = 1.35;       ///< metres; CamVid gives none: 1.2-1.5 m is assumed, we take the middle
  std::optional<double> focal;       ///< pixels (fx = fy); unknown by default (mono SfM estimates it)
  int max_gap = 60;                  ///< a gap of more video frames than this starts a new run
  void validate() const;             ///< Error naming the option if a value is out of range
};

struct CamvidRun {
  std::string name;    ///< e.g. "0016E5_07959-08159"
  std::string camvid_sequence;  ///< e.g. "0016E5"
  std::string split;
  int frames = 0;
  int frame_gap = 0;   ///< typical gap between frames, in video frames (2 = 15 Hz, 30 = 1 Hz)
  fs::path folder;     ///< where its sequence.json was written
};

/// A class table in CamVid's classes.csv form (index,name,r,g,b; the row named Void is the ignore label).
struct CamvidClasses {
  std::vector<ClassInfo> classes;
  ClassInfo void_class;
};
/// Errors name the file and line (a bad number or colour, no Void row, no class).
CamvidClasses read_camvid_classes(const fs::path& file);

/// Reads dir/frames.csv and dir/classes.csv and writes out/<run name>/sequence.json per run plus
/// out/index.json listing the runs. Checks that each image named exists (sizes are read from the first
/// image of each run and must agree). Errors name the file and line.
std::vector<CamvidRun> import_camvid(const fs::path& dir, const fs::path& out, const CamvidImportOptions& opt);

}  // namespace smseg::sequence
