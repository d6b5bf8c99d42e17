#pragma once
// Left-right mirrored training frames (train-forest --mirror): each labelled frame is also given to the
// trees as its mirror image, a second street seen from the other side. Driving scenes are close to
// symmetric about the vertical (cars and poles on either side, the road between), so the mirror is
// a frame the trees could have met; the sample of the small classes doubles at no extraction cost.
//
// A channel of the mirrored frame is made from the frame's own summed-area tables, never from the
// image again (the structure-and-motion channels have no image to come from):
//   flip     f'(x, y) = f(W-1-x, y), for what does not depend on left and right: heights, distances,
//            depth, density, residuals, colour, the up component of a normal, posteriors (fCtx:*);
//   negate   the same, times -1: fOx, the world normal's x component (the world's x is the first
//            camera's right, which the mirror turns round);
//   swap     fG1 (gradients at 45 degrees) and fG3 (135 degrees) trade places: a mirror turns a
//            gradient at angle a into one at 180 - a (fG0 and fG2, 0 and 90 degrees, stay);
//   keep     fCol, the pixel's column position: the mirrored frame's column channel is the same
//            raster (x + 0.5) / W, not the mirror of it.
// Texton channels (fTx*) are refused: their filter bank's odd filters change sign under the mirror,
// so the mirrored frame's texton map is not the mirror of the frame's. An unknown channel is refused
// too rather than guessed.
// The tables are mirrored exactly in arithmetic (S'(x, y) = S(W, y) - S(W - x, y)), so a window's sum
// on the mirrored frame equals the mirrored window's on the frame up to rounding.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace smseg::stacks {

/// How one channel of the mirrored frame is made.
struct ChannelMirror {
  std::size_t source = 0;  ///< the channel of the frame it is made from (itself, or fG1 / fG3's partner)
  bool flip = true;        ///< mirror the raster left to right (false: fCol, the same raster)
  bool negate = false;     ///< and change its sign (fOx)
};

/// The plan for a frame with these channels, in their order. Error(source, "features", ...) naming a
/// channel with no mirror (textons, unknown names) or fG1 / fG3 without its partner.
std::vector<ChannelMirror> mirror_plan(const std::vector<std::string>& features, const std::string& source);

/// The summed-area table ((height+1) x (width+1), row-major) of the mirrored raster, from the raster's
/// own table; with `negate` of minus the raster.
void mirror_table(const double* table, int width, int height, bool negate, double* out);

/// A height x width image mirrored left to right.
void mirror_image(const std::uint8_t* image, int width, int height, std::uint8_t* out);

}  // namespace smseg::stacks
