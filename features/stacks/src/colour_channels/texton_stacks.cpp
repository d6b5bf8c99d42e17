// Textons on work folders: the samples learn-textons clusters, the channels add-textons writes
// (textons.hpp).
#include <oneapi/tbb/parallel_for.h>

#include "smseg/common/digest.hpp"
#include "smseg/common/error.hpp"
#include "smseg/common/progress.hpp"
#include "smseg/sequence/sequence.hpp"
#include "smseg/stacks/extension.hpp"
#include "smseg/stacks/textons.hpp"
#include "learned_files.hpp"

namespace smseg::stacks {

cv::Mat texton_samples(const std::vector<fs::path>& works, const FrameRange& range, int per_frame, std::uint64_t seed,
                       bool progress) {
  if (works.empty()) throw Error("", "WORK", "name at least one work folder");
  if (per_frame < 1) throw Error("", "--samples", "is " + std::to_string(per_frame) + ", expected >= 1");
  std::vector<cv::Mat> parts;
  for (std::size_t w = 0; w < works.size(); ++w) {
    const StackManifest m = load_stack_manifest(works[w]);
    const sequence::Sequence seq = sequence::load_sequence(m.sequence);
    const std::vector<int> frames = frames_in_range(m, range);
    std::vector<cv::Mat> samples(frames.size());
    Progress bar("learn-textons " + m.work.filename().string(), static_cast<long>(frames.size()), progress);
    tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t i) {
      samples[i] = sample_filter_responses(colour_image(seq, m, frames[i]), per_frame, frame_seed(seed, w, frames[i]));
      bar.tick();
    });
    parts.insert(parts.end(), samples.begin(), samples.end());
  }
  cv::Mat all;
  cv::vconcat(parts, all);
  return all;
}

int add_texton_channels(const TextonDictionary& dictionary, const fs::path& dictionary_file,
                        const std::vector<fs::path>& works, const std::vector<fs::path>& outs,
                        const FrameRange& range, bool progress) {
  ColourChannels textons;
  textons.tool = "add-textons";
  textons.names = dictionary.feature_names();
  textons.is_own = is_texton_feature;
  textons.options_key = "textons";
  textons.options = {{"dictionary", fs::absolute(dictionary_file).lexically_normal().string()},
                     {"dictionary_fnv1a64", fnv1a64_hex(read_file(dictionary_file))},
                     {"textons", dictionary.count()}};
  textons.rasters = [&dictionary](const cv::Mat& bgr) {
    return texton_rasters(assign_textons(bgr, dictionary), dictionary.count());
  };
  return add_colour_channels(textons, works, outs, range, progress);
}

}  // namespace smseg::stacks
