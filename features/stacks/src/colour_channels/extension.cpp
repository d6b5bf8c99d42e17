// Work folders extended with channels of the colour images (extension.hpp).
#include "smseg/stacks/extension.hpp"

#include <algorithm>

#include <oneapi/tbb/parallel_for.h>

#include "smseg/common/error.hpp"
#include "smseg/common/output.hpp"
#include "smseg/common/progress.hpp"

namespace smseg::stacks {

cv::Mat colour_image(const sequence::Sequence& seq, const StackManifest& m, int f) {
  cv::Mat bgr = seq.load_left(f);
  if (bgr.size() != m.size)
    throw Error(m.manifest_path().string(), "image_size",
                "is " + std::to_string(m.size.width) + "x" + std::to_string(m.size.height) + ", but frame " +
                    std::to_string(f) + " of " + seq.manifest.string() + " is " + std::to_string(bgr.cols) + "x" +
                    std::to_string(bgr.rows));
  return bgr;
}

int add_colour_channels(const ColourChannels& added, const std::vector<fs::path>& works,
                        const std::vector<fs::path>& outs, const FrameRange& range, bool progress) {
  if (works.empty()) throw Error("", "WORK", "name at least one work folder");
  if (works.size() != outs.size()) throw Error("", "WORK", "one output folder per work folder");
  std::vector<StackManifest> sources;
  for (const auto& w : works) {  // every check before any work
    sources.push_back(load_stack_manifest(w));
    const StackManifest& m = sources.back();
    const auto own = std::find_if(m.features.begin(), m.features.end(), added.is_own);
    if (own != m.features.end())
      throw Error(m.manifest_path().string(), "features",
                  "already has the channel " + *own + ": give " + added.tool + " the folder it extends");
    if (added.check_folder) added.check_folder(m);
    frames_in_range(m, range);
  }
  int written = 0;
  for (std::size_t w = 0; w < works.size(); ++w) {
    const StackManifest& m = sources[w];
    StackManifest out = extending_manifest(m, outs[w], m.features, added.names);
    out.options[added.options_key] = added.options;
    out.options[added.options_key]["frames"] = range.str();
    const sequence::Sequence seq = sequence::load_sequence(m.sequence);
    const std::vector<int> frames = frames_in_range(m, range);
    Progress bar(added.tool + " " + m.work.filename().string(), static_cast<long>(frames.size()), progress);
    tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t i) {
      write_frame_values(out.work, frames[i], m.size, added.rasters(colour_image(seq, m, frames[i])), cv::Mat(), cv::Mat());
      bar.tick();
    });
    for (int f : frames) {
      out.frames.push_back(f);
      if (m.is_labelled(f)) out.labelled_frames.push_back(f);
    }
    save_stack_manifest(out);
    written += static_cast<int>(frames.size());
  }
  return written;
}

int write_extending_folders(
    const std::vector<std::string>& works, const fs::path& out, const std::string& frames,
    std::initializer_list<fs::path> other_inputs,
    const std::function<int(const std::vector<fs::path>& works, const std::vector<fs::path>& outs, const FrameRange&)>&
        write) {
  const FrameRange range = FrameRange::parse(frames, "--frames");
  const OutputLock one_writer(out, paths_of(works, other_inputs));
  FolderReplacement replacement(out);
  const std::vector<fs::path> outs = folders_by_name(works, replacement.staging());
  const int written = write(std::vector<fs::path>(works.begin(), works.end()), outs, range);
  replacement.commit();
  return written;
}

}  // namespace smseg::stacks
