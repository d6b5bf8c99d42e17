// Textons on work folders: the samples learn-textons clusters, the channels add-textons writes
// (textons.hpp).
#include <algorithm>

#include <oneapi/tbb/parallel_for.h>

#include "smseg/common/digest.hpp"
#include "smseg/common/error.hpp"
#include "smseg/common/progress.hpp"
#include "smseg/sequence/sequence.hpp"
#include "smseg/stacks/textons.hpp"

namespace smseg::stacks {

namespace {

/// Frame f's colour image from the folder's sequence, checked against the stacks' size.
cv::Mat colour_image(const sequence::Sequence& seq, const StackManifest& m, int f) {
  cv::Mat bgr = seq.load_left(f);
  if (bgr.size() != m.size)
    throw Error(m.manifest_path().string(), "image_size",
                "is " + std::to_string(m.size.width) + "x" + std::to_string(m.size.height) + ", but frame " +
                    std::to_string(f) + " of " + seq.manifest.string() + " is " + std::to_string(bgr.cols) + "x" +
                    std::to_string(bgr.rows));
  return bgr;
}

std::uint64_t frame_seed(std::uint64_t seed, std::size_t folder, int frame) {
  return seed ^ (0x9E3779B97F4A7C15ULL * (1 + folder * 1000003ULL + static_cast<std::uint64_t>(frame)));
}

}  // namespace

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
  if (works.empty()) throw Error("", "WORK", "name at least one work folder");
  if (works.size() != outs.size()) throw Error("", "WORK", "one output folder per work folder");
  const std::vector<std::string> added = dictionary.feature_names();
  std::vector<StackManifest> sources;
  for (const auto& w : works) {  // every check before any work
    sources.push_back(load_stack_manifest(w));
    const StackManifest& m = sources.back();
    if (std::any_of(m.features.begin(), m.features.end(), is_texton_feature))
      throw Error(m.manifest_path().string(), "features", "already has texton channels (fTx...): give add-textons the folder they extend");
    frames_in_range(m, range);
  }
  int written = 0;
  for (std::size_t w = 0; w < works.size(); ++w) {
    const StackManifest& m = sources[w];
    StackManifest out = extending_manifest(m, outs[w], m.features, added);
    out.options["textons"] = {{"dictionary", fs::absolute(dictionary_file).lexically_normal().string()},
                              {"dictionary_fnv1a64", fnv1a64_hex(read_file(dictionary_file))},
                              {"textons", dictionary.count()},
                              {"frames", range.str()}};
    const sequence::Sequence seq = sequence::load_sequence(m.sequence);
    const std::vector<int> frames = frames_in_range(m, range);
    Progress bar("add-textons " + m.work.filename().string(), static_cast<long>(frames.size()), progress);
    tbb::parallel_for(std::size_t{0}, frames.size(), [&](std::size_t i) {
      const cv::Mat index = assign_textons(colour_image(seq, m, frames[i]), dictionary);
      write_frame_values(out.work, frames[i], m.size, texton_rasters(index, dictionary.count()), cv::Mat(), cv::Mat());
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

}  // namespace smseg::stacks
