#pragma once
// Stereo disparity for the stereo front end (thesis 3.2.2, docs/design.md section 4 "Point tracking").
//
// The default is cross-correlation block matching with a validity check, the equivalent of the
// Triclops library the thesis used: OpenCV StereoBM with its texture and uniqueness thresholds, then
// an explicit left-right consistency check (the right-image disparity is computed by the same matcher
// on the mirrored pair, right-flipped as left and left-flipped as right; a left pixel survives when the
// right disparity at x - d agrees within `lr_max_diff` pixels), then speckle removal (the "surface
// validation" of Triclops). Semi-global matching (StereoSGBM, its own left-right check through
// disp12MaxDiff) is the alternative, and a precomputed disparity from the sequence is the third source.
// Sparse is BM matched only at the pixels the front end reads (sparse_stereo.hpp): the same
// disparities there, without the speckle filter.
//
// Disparity maps in memory: CV_32FC1 in pixels, left image, d = x_left - x_right; -1 where invalid
// (every value <= 0 means "no depth").
//
// Also here: the Middlebury 2014 helpers (PFM, calib.txt) and the scoring used by `eval-stereo`.

#include <cstdint>
#include <string>

#include <opencv2/core.hpp>

#include "smseg/sequence/sequence.hpp"

namespace smseg::frontend {

inline constexpr float kInvalidDisparity = -1.0f;

enum class StereoMethod { BM, SGBM, Given, Sparse };

/// "bm" | "sgbm" | "given" | "sparse"; anything else is an Error naming `field`.
StereoMethod parse_stereo_method(const std::string& name, const std::string& field = "stereo.method");
const char* stereo_method_name(StereoMethod m);

/// BM's left-right check: the right-image disparity from the same matcher on the mirrored pair (a
/// second full match, with its own texture, uniqueness and speckle filtering: the stricter check), or
/// OpenCV's own check from the left match's costs (disp12MaxDiff: half the matching time, a weaker
/// check; docs/stereo.md "Matchers").
enum class LeftRightCheck { Mirrored, Matcher };
LeftRightCheck parse_left_right_check(const std::string& name, const std::string& field = "stereo.lr_check");
const char* left_right_check_name(LeftRightCheck c);

struct StereoOptions {
  StereoMethod method = StereoMethod::BM;
  int min_disparity = 0;      ///< smallest disparity searched, pixels
  int num_disparities = 64;   ///< size of the search range, a positive multiple of 16
  int block_size = 11;        ///< matching window side, odd; BM: 5..255, SGBM: 1..11
  int texture_threshold = 10; ///< BM: windows whose summed |prefiltered| texture is below are invalid (0 = off)
  int uniqueness_ratio = 15;  ///< percent by which the best cost must beat the second best (0 = off)
  int lr_max_diff = 1;        ///< left-right check tolerance in pixels; < 0 disables the check
  LeftRightCheck lr_check = LeftRightCheck::Mirrored;  ///< BM: how the left-right check is made
  int speckle_window = 50;    ///< connected regions of fewer pixels are invalidated (0 = off)
  int speckle_range = 2;      ///< max disparity step (pixels) inside one speckle region
  int prefilter_cap = 31;     ///< 1..63, clamp of the prefiltered image (BM and SGBM)
  bool sgbm_full_paths = false;  ///< SGBM: all eight paths (MODE_HH; more memory, fewer errors on slanted surfaces)
  /// Throws Error("", "stereo.<field>", reason) for an out-of-range value.
  void validate() const;
};

/// Disparity of the left image from a rectified pair (CV_8UC1 or CV_8UC3, equal sizes) with
/// options.method BM, SGBM or Sparse (every pixel matched one by one: slow, for tests and eval-stereo). Error for mismatched sizes, wrong types, or method Given.
cv::Mat compute_disparity(const cv::Mat& left, const cv::Mat& right, const StereoOptions& options);

/// Invalidates (sets to -1) every left pixel whose disparity d is not confirmed by the right-image
/// disparity at x - round(d) within max_diff pixels. Both CV_32FC1, same size; returns the count removed.
long left_right_check(cv::Mat& left_disparity, const cv::Mat& right_disparity, double max_diff);

/// A pair whose images are offset against each other (Calibration::disparity_offset): `offset` pixels
/// added to every valid (> 0) disparity, and one that is then not positive made invalid (-1). A no-op
/// for 0 (the disparities stay bit for bit).
void apply_disparity_offset(cv::Mat& disparity, double offset);

/// The disparity of one frame of a stereo sequence: computed from its left/right images (BM, SGBM;
/// with the calibration's disparity_offset applied), or loaded (Given: already true disparities).
/// Values <= 0 are normalised to -1.
cv::Mat frame_disparity(const sequence::Sequence& seq, int frame, const StereoOptions& options);

// ---------------------------------------------------------------------------------------------
// Middlebury 2014 (MiddEval3) helpers, for measuring the matchers on real pairs.

/// Reads a PFM greyscale image ("Pf"), any endianness, into CV_32FC1 top row first (PFM stores the
/// bottom row first). inf / nan are kept. Error naming the file for anything malformed.
cv::Mat read_pfm(const fs::path& path);
/// Writes CV_32FC1 as little-endian PFM, atomically.
void write_pfm(const fs::path& path, const cv::Mat& image);

struct MiddleburyCalib {
  double fx = 0, fy = 0, cx0 = 0, cx1 = 0, cy = 0;
  double doffs = 0;     ///< cx1 - cx0 as written in the file
  double baseline = 0;  ///< millimetres, as in the file
  int width = 0, height = 0, ndisp = 0;
  int vmin = 0, vmax = 0;
};

/// Parses calib.txt (key=value lines, whitespace tolerant; cam0/cam1 as "[f 0 cx; 0 f cy; 0 0 1]").
MiddleburyCalib read_middlebury_calib(const fs::path& path);

struct DisparityScore {
  long pixels = 0;           ///< all pixels
  long valid = 0;            ///< pixels with an estimated disparity (> 0)
  long evaluated = 0;        ///< non-occluded, finite ground truth, and valid estimate
  long bad = 0;              ///< of evaluated, |d - d_gt| > threshold
  long nonocc_known = 0;     ///< non-occluded pixels with finite ground truth
  double valid_share = 0;    ///< valid / pixels
  double nonocc_valid_share = 0;  ///< evaluated / nonocc_known
  double bad_rate = 0;       ///< bad / evaluated (0 when nothing was evaluated)
  double mean_abs_error = 0; ///< mean |d - d_gt| over evaluated
};

/// Scores an estimate (CV_32FC1, <= 0 or non-finite = invalid) against ground truth (CV_32FC1,
/// non-finite or <= 0 = unknown) over the non-occluded mask (CV_8UC1, 255 = non-occluded; empty = all).
DisparityScore score_disparity(const cv::Mat& estimate, const cv::Mat& ground_truth, const cv::Mat& nonocc_mask,
                               double bad_threshold = 2.0);

}  // namespace smseg::frontend
