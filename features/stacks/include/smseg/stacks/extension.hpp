#pragma once
// Work folders that extend others with channels made from the colour images (add-textons, add-people):
// the one loop they share, so that every such tool checks, names and writes its folders alike.

#include <functional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/common/io.hpp"
#include "smseg/sequence/sequence.hpp"
#include "smseg/stacks/stack.hpp"

namespace smseg::stacks {

/// Frame f's colour image from the folder's sequence; Error naming stacks.json when its size is not the
/// stacks'.
cv::Mat colour_image(const sequence::Sequence& seq, const StackManifest& m, int f);

/// What an extending tool adds to each frame.
struct ColourChannels {
  std::string tool;                       ///< "add-textons": in errors and the progress bar
  std::vector<std::string> names;         ///< the channels it adds, in raster order
  std::function<bool(const std::string&)> is_own;  ///< a feature it would add (a folder with one is refused)
  std::string options_key;                ///< stacks.json's options.<key> records `options`
  Json options = Json::object();
  /// Checks a folder before any is written (Error naming its stacks.json when the channels do not fit
  /// it, e.g. a model of other classes); empty: every folder fits.
  std::function<void(const StackManifest&)> check_folder;
  /// The channels of one colour image (BGR, CV_8UC3): names.size() CV_64FC1 rasters of its size. Called
  /// from several threads at once.
  std::function<std::vector<cv::Mat>(const cv::Mat& bgr)> rasters;
};

/// Writes, for each works[i], the work folder outs[i] that extends it (all its features, read from it as
/// its base) with `added`'s channels of each frame inside `frames` (labels and greyscale as in
/// works[i]). Errors name the file: a folder that already has one of the channels, a folder without a
/// frame in range, a colour image of another size than the stacks'. Returns the frames written.
int add_colour_channels(const ColourChannels& added, const std::vector<fs::path>& works,
                        const std::vector<fs::path>& outs, const FrameRange& frames, bool progress);

/// What add-textons and add-people do with their command line: parse `frames` (--frames), claim `out`
/// as its one writer (apart from `works` and `other_inputs`), have `write` build OUT/<name of each
/// WORK> beside it, then swap it in whole. Returns what `write` returns (the frames written).
int write_extending_folders(
    const std::vector<std::string>& works, const fs::path& out, const std::string& frames,
    std::initializer_list<fs::path> other_inputs,
    const std::function<int(const std::vector<fs::path>& works, const std::vector<fs::path>& outs, const FrameRange&)>&
        write);

}  // namespace smseg::stacks
