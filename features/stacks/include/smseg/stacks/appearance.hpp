#pragma once
// Appearance channels (extract-features --appearance): what the image itself says at each pixel, as
// rasters the forest's windows average like the structure-and-motion features (summed-area tables).
//   fL fA fB          CIE Lab colour of the left image (sRGB, D65; L* / 100, (a* + 128) / 255, (b* + 128) / 255:
//                     OpenCV's 8-bit Lab scaling without its rounding, each about [0, 1])
//   fG0 fG1 fG2 fG3   gradient magnitude of the greyscale image (3x3 Sobel, / (4 * 255 * sqrt 2): in
//                     [0, 1]) shared between four orientation bins, 0, 45, 90 and 135 degrees (the
//                     gradient's direction modulo 180), linearly between the two nearest: a window's
//                     mean is a 4-bin histogram of oriented gradients
//   fRow fCol         the pixel's position, (y + 0.5) / H and (x + 0.5) / W: a window's mean is where
//                     it lies in the image (a location prior; CamVid's sky is on top, its road below)
// None of them reads the structure or motion: forests that use them are "S+M + appearance" in the
// CamVid figures (docs/camvid.md), and `train-forest --features` leaves them out for S+M-only runs.

#include <string>
#include <vector>

#include <opencv2/core.hpp>

namespace smseg::stacks {

/// {"fL", "fA", "fB", "fG0", "fG1", "fG2", "fG3", "fRow", "fCol"}, in raster order.
const std::vector<std::string>& appearance_feature_names();

/// Whether `name` is one of appearance_feature_names().
bool is_appearance_feature(const std::string& name);

/// Appends the appearance rasters of a BGR image (CV_8UC3; Error otherwise or when empty) to `out`, in
/// appearance_feature_names() order, each CV_64FC1 of the image's size.
void append_appearance_rasters(const cv::Mat& bgr, std::vector<cv::Mat>& out);

/// Appends fL, fA and fB alone (the first three of append_appearance_rasters; the textons' filter bank
/// reads them).
void append_lab_rasters(const cv::Mat& bgr, std::vector<cv::Mat>& out);

}  // namespace smseg::stacks
