#pragma once
// Darker copies of the training frames (train-forest --exposures): each labelled frame is also given to
// the trees as the camera would have seen it with k times the light (k < 1), so that colour and
// gradient tests learned on daylight frames do not take a dusk sky, darker than any daylight sky, for
// a building.
//
// Exposure scales the light reaching the sensor: the linear RGB values times k. Through the formulas of
// the appearance channels (appearance.hpp) that is an affine map of each channel, exact where noted:
//   fL fA fB   Lab's cube root scales X, Y and Z's roots by c = k^(1/3), so L* + 16, a* and b* scale by c:
//              fL' = c (fL + 0.16) - 0.16, fA' = c (fA - 128/255) + 128/255, fB' likewise (exact above
//              Lab's linear toe, Y > 0.008856, i.e. L* > 8: all but near-black pixels);
//   fG0..fG3   the greyscale image is sRGB-encoded, V / 255 = 1.055 lin^(1/2.4) - 0.055, so V + 14.025
//              scales by g = k^(1/2.4) and the Sobel gradient (linear in V) by g: fG' = g fG (exact on
//              sRGB's power segment, V > 10, and up to the 8-bit rounding of the darker image);
//   the rest   the structure-and-motion, dense and position channels do not see the light: as they are.
// The greyscale image (texton tests) is mapped likewise and rounded. Texton (fTx*) and auto-context
// (fCtx:*) channels are refused: they are functions of the image that no affine map follows. Brighter
// copies (k > 1) are refused too: a brighter image saturates at 255, which the tables cannot know.
// A channel's table maps as its raster does: S'(x, y) = scale S(x, y) + offset x y.

#include <cstdint>
#include <string>
#include <vector>

namespace smseg::stacks {

/// How one channel of the darker frame is made from the same channel of the frame: f' = scale f + offset.
struct ChannelExposure {
  double scale = 1.0;
  double offset = 0.0;
  bool unchanged() const { return scale == 1.0 && offset == 0.0; }
};

/// The exposures a training may ask for: 0.01 <= k <= 0.99. UsageError-like Error(source = "", option, ...)
/// naming `option` otherwise.
void check_exposure(double k, const std::string& option);

/// Each of them checked, and none given twice (Error naming `option`).
void check_exposures(const std::vector<double>& exposures, const std::string& option);

/// The plan for a frame with these channels, in their order, at exposure k. Error(source, "features", ...)
/// naming a channel that no exposure map follows (textons, auto-context, unknown names).
std::vector<ChannelExposure> exposure_plan(const std::vector<std::string>& features, double k,
                                           const std::string& source);

/// The plan that brings a frame whose mean fL is `mean_l` to mean `target` (lightness normalisation,
/// TrainParams::lightness): the exposure map with c = (target + 0.16) / (mean_l + 0.16), so the mapped
/// mean is the target exactly. A darker frame is brightened (c > 1): the map then ignores that the
/// brighter image would have saturated. Error(source, "features", ...) as exposure_plan, or when the
/// channels have no fL to measure the frame by.
std::vector<ChannelExposure> lightness_plan(const std::vector<std::string>& features, double mean_l, double target,
                                            const std::string& source);

/// The exposure (light factor k = c^3) a lightness plan applies, for the greyscale image.
double lightness_exposure(double mean_l, double target);

/// The summed-area table ((height+1) x (width+1), row-major) of scale f + offset, from f's own table.
void exposed_table(const double* table, int width, int height, ChannelExposure e, double* out);

/// A height x width sRGB-encoded greyscale image as it would be at exposure k > 0 (rounded, clamped to
/// 0..255).
void exposed_gray(const std::uint8_t* image, int width, int height, double k, std::uint8_t* out);

}  // namespace smseg::stacks
