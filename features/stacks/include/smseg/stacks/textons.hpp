#pragma once
// Textons (Malik et al. 2001; Winn, Criminisi & Minka 2005; Shotton et al.'s TextonBoost 2006, the
// appearance half of the CamVid anchors): each pixel's responses to a 17-filter bank, quantised to the
// nearest of K cluster centres that k-means learned on training images. `add-textons` writes the K
// indicator channels fTx0..fTx<K-1> (1 where the pixel's texton is k, else 0) beside a work folder's
// stacks, so that a forest window's mean over channel k is the share of texton k in the window: the
// texture-layout features of TextonBoost, with the forest's offset windows as its rectangles.
//
// The filter bank (Winn et al.'s 17 filters), on CIE Lab (appearance.hpp's, L* / 100 and a*, b* in about
// [0, 1]):
//   Gaussians, sigma 1, 2, 4, on L, a and b                       (9)
//   Laplacians of Gaussians, sigma 1, 2, 4, 8, on L, times sigma^2 (4)
//   x and y derivatives of Gaussians, sigma 2, 4, on L, times sigma (4)
// Each response is made a z-score with the mean and spread of the training samples before clustering
// and before each pixel is given its nearest centre (squared Euclidean distance; a tie goes to the lower
// index). The same images, options and seed give the same dictionary whatever the thread count.

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "smseg/common/io.hpp"
#include "smseg/stacks/stack.hpp"

namespace smseg::stacks {

inline constexpr int kFilterBankSize = 17;
inline constexpr const char* kTextonPrefix = "fTx";
inline constexpr const char* kTextonFormat = "smseg-textons";
inline constexpr int kMaxTextons = 255;  ///< an index fits a byte

/// The learned textons: a z-score per filter response, then K centres in z-score units.
struct TextonDictionary {
  std::vector<double> mean;    ///< per response, over the training samples
  std::vector<double> scale;   ///< per response, 1 / standard deviation (1 where it was 0)
  cv::Mat centres;             ///< K x kFilterBankSize, CV_32FC1
  Json provenance = Json::object();  ///< what it was learned from (the tool's record)

  int count() const { return centres.rows; }
  /// "fTx0" .. "fTx<K-1>".
  std::vector<std::string> feature_names() const;
};

/// Whether a feature name is a texton channel.
bool is_texton_feature(const std::string& name);

/// The filter bank's responses of a BGR image (CV_8UC3, not empty; Error otherwise): one row of
/// kFilterBankSize floats per pixel, rows in raster order (CV_32FC1, H*W x 17).
cv::Mat filter_bank_responses(const cv::Mat& bgr);

/// `count` rows of filter_bank_responses(bgr) at pixels drawn uniformly (with replacement) by a
/// generator seeded with `seed`.
cv::Mat sample_filter_responses(const cv::Mat& bgr, int count, std::uint64_t seed);

struct TextonLearning {
  int textons = 32;       ///< K, 2..kMaxTextons
  int iterations = 30;    ///< k-means iterations at most (it stops earlier when the centres settle)
  std::uint64_t seed = 1; ///< k-means++ seeding
};

/// k-means++ then Lloyd's iterations on z-scored samples (rows of kFilterBankSize floats, at least
/// `textons` of them; Error naming "samples" otherwise).
TextonDictionary learn_textons(const cv::Mat& samples, const TextonLearning& options);

/// Each pixel's texton (CV_8UC1 of the image's size).
cv::Mat assign_textons(const cv::Mat& bgr, const TextonDictionary& dictionary);

/// The indicator rasters of a texton image: `count` CV_64FC1 rasters, raster k 1 where index == k.
std::vector<cv::Mat> texton_rasters(const cv::Mat& index, int count);

/// Writes the dictionary as JSON (format "smseg-textons" version 1), atomically.
void save_texton_dictionary(const fs::path& path, const TextonDictionary& dictionary);
/// Reads and checks a dictionary file; Error naming the file and the field.
TextonDictionary load_texton_dictionary(const fs::path& path);

// ---- on work folders (learn-textons, add-textons) ----

/// Training samples: `per_frame` responses at random pixels of the colour image (read from the folder's
/// sequence) of every frame of each work folder inside `frames`, in folder then frame order; each
/// frame's pixels drawn with a seed made from `seed`, the folder's place and the frame.
cv::Mat texton_samples(const std::vector<fs::path>& works, const FrameRange& frames, int per_frame,
                       std::uint64_t seed, bool progress);

/// Writes, for each works[i], the work folder outs[i] that extends it (all its features, read from it as
/// its base) with the dictionary's indicator channels fTx0..fTx<K-1> of each frame inside `frames`
/// (labels and greyscale as in works[i]); stacks.json records the dictionary under options.textons.
/// Errors name the file: a folder that already has texton channels, a folder without a frame in range,
/// a colour image of another size than the stacks'. Returns the frames written.
int add_texton_channels(const TextonDictionary& dictionary, const fs::path& dictionary_file,
                        const std::vector<fs::path>& works, const std::vector<fs::path>& outs,
                        const FrameRange& frames, bool progress);

}  // namespace smseg::stacks
