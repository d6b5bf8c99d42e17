#include "smseg/frontend/stereo.hpp"

#include "smseg/common/names.hpp"
#include "smseg/frontend/sparse_stereo.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <string>

#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace smseg::frontend {

namespace {

[[noreturn]] void bad_option(const std::string& field, const std::string& reason) {
  throw Error("", "stereo." + field, reason);
}

cv::Mat to_gray(const cv::Mat& m, const char* which) {
  if (m.empty()) throw Error("", which, "empty image");
  if (m.depth() != CV_8U) throw Error("", which, "expected an 8-bit image");
  if (m.channels() == 1) return m;
  cv::Mat g;
  if (m.channels() == 3) {
    cv::cvtColor(m, g, cv::COLOR_BGR2GRAY);
  } else if (m.channels() == 4) {
    cv::cvtColor(m, g, cv::COLOR_BGRA2GRAY);
  } else {
    throw Error("", which, "expected 1, 3 or 4 channels");
  }
  return g;
}

cv::Ptr<cv::StereoMatcher> make_matcher(const StereoOptions& o) {
  if (o.method == StereoMethod::BM) {
    auto bm = cv::StereoBM::create(o.num_disparities, o.block_size);
    bm->setMinDisparity(o.min_disparity);
    bm->setTextureThreshold(o.texture_threshold);
    bm->setUniquenessRatio(o.uniqueness_ratio);
    bm->setPreFilterCap(o.prefilter_cap);
    bm->setSpeckleWindowSize(o.speckle_window);
    bm->setSpeckleRange(o.speckle_range);
    // The mirrored check is made below (compute_disparity); the matcher's own from its costs.
    bm->setDisp12MaxDiff(o.lr_check == LeftRightCheck::Matcher && o.lr_max_diff >= 0 ? o.lr_max_diff : -1);
    return bm;
  }
  const int cn = 1;
  const int b2 = o.block_size * o.block_size;
  auto sg = cv::StereoSGBM::create(o.min_disparity, o.num_disparities, o.block_size, 8 * cn * b2, 32 * cn * b2,
                                   o.lr_max_diff >= 0 ? o.lr_max_diff : -1, o.prefilter_cap, o.uniqueness_ratio,
                                   o.speckle_window, o.speckle_range,
                                   o.sgbm_full_paths ? cv::StereoSGBM::MODE_HH : cv::StereoSGBM::MODE_SGBM);
  return sg;
}

// Fixed-point (x16) CV_16S disparity -> CV_32F pixels, -1 where invalid or <= 0. The matchers mark
// invalid pixels (min_disparity - 1) x 16, which is positive from min_disparity 2 on; their smallest
// real value is above it (min_disparity x 16 less half a pixel's sub-pixel step).
cv::Mat fixed_to_float(const cv::Mat& raw, int min_disparity) {
  const int invalid = std::max(0, (min_disparity - 1) * 16);
  cv::Mat out(raw.size(), CV_32FC1);
  for (int y = 0; y < raw.rows; ++y) {
    const auto* r = raw.ptr<std::int16_t>(y);
    auto* o = out.ptr<float>(y);
    for (int x = 0; x < raw.cols; ++x) o[x] = r[x] > invalid ? static_cast<float>(r[x]) / 16.0f : kInvalidDisparity;
  }
  return out;
}

}  // namespace

namespace {
constexpr std::array<EnumName<StereoMethod>, 4> kStereoMethodNames{{{StereoMethod::BM, "bm"},
                                                                     {StereoMethod::SGBM, "sgbm"},
                                                                     {StereoMethod::Given, "given"},
                                                                     {StereoMethod::Sparse, "sparse"}}};
}  // namespace

namespace {
constexpr std::array<EnumName<LeftRightCheck>, 2> kLeftRightCheckNames{
    {{LeftRightCheck::Mirrored, "mirrored"}, {LeftRightCheck::Matcher, "matcher"}}};
}  // namespace

LeftRightCheck parse_left_right_check(const std::string& name, const std::string& field) {
  return value_named(kLeftRightCheckNames, name, field);
}
const char* left_right_check_name(LeftRightCheck c) { return name_of(kLeftRightCheckNames, c); }

StereoMethod parse_stereo_method(const std::string& name, const std::string& field) {
  return value_named(kStereoMethodNames, name, field);
}
const char* stereo_method_name(StereoMethod m) { return name_of(kStereoMethodNames, m); }

void StereoOptions::validate() const {
  if (method == StereoMethod::Given) return;  // the matcher's parameters are not used
  if (num_disparities <= 0 || num_disparities % 16 != 0)
    bad_option("num_disparities", "must be a positive multiple of 16, got " + std::to_string(num_disparities));
  if (min_disparity < 0 || min_disparity > 1000)
    bad_option("min_disparity", "must be in 0..1000, got " + std::to_string(min_disparity));
  if (block_size % 2 == 0) bad_option("block_size", "must be odd, got " + std::to_string(block_size));
  const bool block_matching = method == StereoMethod::BM || method == StereoMethod::Sparse;
  if (block_matching && (block_size < 5 || block_size > 255))
    bad_option("block_size", "must be in 5..255 for " + std::string(stereo_method_name(method)) + ", got " +
                                 std::to_string(block_size));
  if (method == StereoMethod::Sparse && lr_check == LeftRightCheck::Matcher)
    bad_option("lr_check", "matcher needs stereo bm (--stereo bm): it is bm's own check from the whole map's costs; "
                           "sparse makes the mirrored one");
  if (method == StereoMethod::SGBM && (block_size < 1 || block_size > 21))
    bad_option("block_size", "must be in 1..21 for sgbm, got " + std::to_string(block_size));
  if (texture_threshold < 0) bad_option("texture_threshold", "must be >= 0");
  if (uniqueness_ratio < 0 || uniqueness_ratio > 100) bad_option("uniqueness_ratio", "must be in 0..100 (percent)");
  if (speckle_window < 0) bad_option("speckle_window", "must be >= 0");
  if (speckle_range < 0) bad_option("speckle_range", "must be >= 0");
  if (prefilter_cap < 1 || prefilter_cap > 63) bad_option("prefilter_cap", "must be in 1..63");
}

long left_right_check(cv::Mat& dl, const cv::Mat& dr, double max_diff) {
  if (dl.type() != CV_32FC1 || dr.type() != CV_32FC1 || dl.size() != dr.size())
    throw Error("", "disparity", "left-right check needs two CV_32FC1 maps of one size");
  long removed = 0;
  for (int y = 0; y < dl.rows; ++y) {
    auto* l = dl.ptr<float>(y);
    const auto* r = dr.ptr<float>(y);
    for (int x = 0; x < dl.cols; ++x) {
      const float d = l[x];
      if (!(d > 0)) continue;
      const int xr = static_cast<int>(std::lround(x - d));
      const bool ok = xr >= 0 && r[xr] > 0 && std::abs(r[xr] - d) <= max_diff;
      if (!ok) {
        l[x] = kInvalidDisparity;
        ++removed;
      }
    }
  }
  return removed;
}

cv::Mat compute_disparity(const cv::Mat& left_in, const cv::Mat& right_in, const StereoOptions& o) {
  o.validate();
  if (o.method == StereoMethod::Given)
    throw Error("", "stereo.method", "'given' reads disparities from the sequence; nothing to compute");
  const cv::Mat left = to_gray(left_in, "left image");
  const cv::Mat right = to_gray(right_in, "right image");
  if (left.size() != right.size())
    throw Error("", "right image",
                "size " + std::to_string(right.cols) + "x" + std::to_string(right.rows) + " differs from the left " +
                    std::to_string(left.cols) + "x" + std::to_string(left.rows));
  if (o.method == StereoMethod::Sparse) return SparseBlockMatcher(left, right, o).dense();
  auto matcher = make_matcher(o);
  // BM and SGBM leave the first min_disparity + num_disparities columns without a disparity (their search
  // would leave the image). Padding both images on the left by that much (edge replicated, textureless)
  // lets those columns be matched against the real image where their match lies inside it.
  const int pad = o.min_disparity + o.num_disparities;
  auto match = [&](const cv::Mat& a, const cv::Mat& b) {
    cv::Mat pa, pb, raw;
    cv::copyMakeBorder(a, pa, 0, 0, pad, 0, cv::BORDER_REPLICATE);
    cv::copyMakeBorder(b, pb, 0, 0, pad, 0, cv::BORDER_REPLICATE);
    matcher->compute(pa, pb, raw);
    return fixed_to_float(raw(cv::Rect(pad, 0, a.cols, a.rows)), o.min_disparity);
  };
  cv::Mat dl = match(left, right);
  if (o.method == StereoMethod::BM && o.lr_check == LeftRightCheck::Mirrored && o.lr_max_diff >= 0) {
    // Right-image disparity: the same matcher on the mirrored pair (right mirrored as the left image).
    cv::Mat lf, rf, dr;
    cv::flip(right, lf, 1);
    cv::flip(left, rf, 1);
    cv::flip(match(lf, rf), dr, 1);
    left_right_check(dl, dr, o.lr_max_diff);
  }
  return dl;
}

void apply_disparity_offset(cv::Mat& disparity, double offset) {
  if (offset == 0) return;
  CV_Assert(disparity.type() == CV_32FC1);
  const auto add = static_cast<float>(offset);
  disparity.forEach<float>([&](float& d, const int*) {
    if (d > 0) d = d + add > 0 ? d + add : kInvalidDisparity;
  });
}

cv::Mat frame_disparity(const sequence::Sequence& seq, int frame, const StereoOptions& o) {
  if (seq.kind != sequence::SequenceKind::Stereo)
    throw Error(seq.manifest.string(), "kind", "the stereo front end needs a stereo sequence");
  if (o.method == StereoMethod::Given) {
    cv::Mat d = seq.load_disparity(frame);
    d.setTo(kInvalidDisparity, ~(d > 0));
    return d;
  }
  try {
    cv::Mat d = compute_disparity(seq.load_left_gray(frame), seq.load_right_gray(frame), o);
    apply_disparity_offset(d, seq.calibration.disparity_offset);
    return d;
  } catch (const Error& e) {
    if (!e.file().empty()) throw;
    throw Error(seq.manifest.string(), "frames[" + std::to_string(frame) + "]", e.what());
  }
}

}  // namespace smseg::frontend
