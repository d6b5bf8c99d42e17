// Procedural textures of the synthetic scenes (see synth.hpp). Every pattern is evaluated at surface
// coordinates in metres and band-limited by the pixel footprint `fp` (metres per pixel on the
// surface): a detail whose period is under ~2 pixels fades to its mean instead of aliasing.
#include <algorithm>
#include <cmath>

#include "synth_detail.hpp"

namespace smseg::synth::detail {

namespace {

inline float clamp01(float x) { return std::min(1.0f, std::max(0.0f, x)); }
inline float smoothstep(float e0, float e1, float x) {
  const float t = clamp01((x - e0) / (e1 - e0));
  return t * t * (3.0f - 2.0f * t);
}

/// Value noise in [0, 1) with smooth interpolation, unit lattice.
float vnoise(float x, float y, std::uint32_t seed) {
  const float fx = std::floor(x), fy = std::floor(y);
  const int ix = static_cast<int>(fx), iy = static_cast<int>(fy);
  float tx = x - fx, ty = y - fy;
  tx = tx * tx * (3.0f - 2.0f * tx);
  ty = ty * ty * (3.0f - 2.0f * ty);
  const float a = lattice(ix, iy, seed), b = lattice(ix + 1, iy, seed);
  const float c = lattice(ix, iy + 1, seed), d = lattice(ix + 1, iy + 1, seed);
  return (a + (b - a) * tx) + ((c + (d - c) * tx) - (a + (b - a) * tx)) * ty;
}

/// 1 for details much coarser than a pixel, 0 for details finer than 2 pixels.
inline float fade(float freq, float fp) { return 1.0f - smoothstep(0.25f, 0.5f, freq * fp); }

/// Zero-mean noise in [-0.5, 0.5) at `freq` cycles per metre, faded by the footprint.
inline float noise(float s, float t, float freq, std::uint32_t seed, float fp) {
  const float f = fade(freq, fp);
  if (f <= 0.0f) return 0.0f;
  return (vnoise(s * freq, t * freq, seed) - 0.5f) * f;
}

/// Coverage (0..1) of lines of width w centred on multiples of `period`, filtered by the footprint.
float lines(float x, float period, float w, float fp) {
  const float avg = w / period;
  if (fp >= 0.5f * period) return avg;
  const float f = x / period;
  const float d = std::abs(f - std::round(f)) * period;
  float cov = clamp01((0.5f * w - d) / std::max(fp, 1e-6f) + 0.5f);
  if (w < fp) cov = std::min(cov, w / fp);
  const float k = smoothstep(0.25f * period, 0.5f * period, fp);
  return cov + (avg - cov) * k;
}

/// Coverage of the interval [lo, hi] at x, filtered by the footprint.
inline float inside(float x, float lo, float hi, float fp) {
  const float w = std::max(fp, 1e-6f);
  return clamp01((x - lo) / w + 0.5f) * clamp01((hi - x) / w + 0.5f);
}
inline float inside2(float s, float t, float s0, float s1, float t0, float t1, float fp) {
  return inside(s, s0, s1, fp) * inside(t, t0, t1, fp);
}

/// Filtered square wave in [-1, 1] of period P (+1 on the first half period).
float square(float x, float period, float fp) {
  const float u = x / period - std::floor(x / period);
  const float raw = u < 0.5f ? 1.0f : -1.0f;
  const float e = std::min({u, std::abs(u - 0.5f), 1.0f - u}) * period;
  const float v = raw * std::min(1.0f, e / std::max(0.5f * fp, 1e-6f));
  return v * (1.0f - smoothstep(0.25f * period, 0.5f * period, fp));
}

/// A pleasant random colour (linear) from a hash: saturated poster colours or muted book colours.
struct Palettes {
  Rgb sat[12 * 5], muted[12 * 5];
  Rgb sat_mean, muted_mean;
  Palettes() {
    static const float kColours[][3] = {
        {0.85f, 0.15f, 0.12f}, {0.95f, 0.75f, 0.10f}, {0.10f, 0.45f, 0.80f}, {0.15f, 0.65f, 0.30f},
        {0.95f, 0.50f, 0.10f}, {0.55f, 0.20f, 0.60f}, {0.10f, 0.10f, 0.12f}, {0.90f, 0.90f, 0.85f},
        {0.20f, 0.70f, 0.75f}, {0.75f, 0.30f, 0.45f}, {0.40f, 0.25f, 0.15f}, {0.60f, 0.65f, 0.20f}};
    for (int i = 0; i < 12; ++i)
      for (int v = 0; v < 5; ++v) {
        const auto& c = kColours[i];
        for (int sat_i = 0; sat_i < 2; ++sat_i) {
          const float k = sat_i ? 1.0f : 0.55f + 0.2f * static_cast<float>(v) / 4.0f;
          const float grey = 0.5f * (1.0f - k);
          const Rgb col{std::pow(c[0] * k + grey * 0.6f, 2.2f), std::pow(c[1] * k + grey * 0.6f, 2.2f),
                        std::pow(c[2] * k + grey * 0.6f, 2.2f)};
          (sat_i ? sat : muted)[i * 5 + v] = col;
        }
      }
    for (int i = 0; i < 60; ++i) {
      sat_mean = sat_mean + sat[i] * (1.0f / 60.0f);
      muted_mean = muted_mean + muted[i] * (1.0f / 60.0f);
    }
  }
};
const Palettes& palettes() {
  static const Palettes p;
  return p;
}
Rgb palette(std::uint32_t h, bool saturated) {
  const int i = static_cast<int>(h % 12) * 5 + static_cast<int>((h >> 8) % 5);
  return saturated ? palettes().sat[i] : palettes().muted[i];
}
/// Average of the palette (what a cell pattern fades to when too small to see).
Rgb palette_mean(bool saturated) { return saturated ? palettes().sat_mean : palettes().muted_mean; }

/// Dark "text": horizontal lines on a light background inside [s0, s1] x [t0, t1].
float text(float s, float t, float s0, float s1, float t0, float t1, float line, std::uint32_t seed, float fp) {
  if (s < s0 - fp || s > s1 + fp || t < t0 - fp || t > t1 + fp) return 0.0f;
  const int row = static_cast<int>(std::floor((t - t0) / line));
  // Ragged right edge per line, and word gaps.
  const float end = s0 + (s1 - s0) * (0.55f + 0.45f * lattice(row, 7, seed));
  const float cov_line = lines(t - t0 + 0.5f * line, line, 0.45f * line, fp);
  const float words = 0.75f + 0.25f * square(s + 0.37f * row, 0.09f + 0.02f * (row % 3), fp);
  return cov_line * inside2(s, t, s0, end, t0, t1, fp) * words;
}

/// A material's three colours (linear) and its seed, as the patterns below read them.
struct Paint {
  Rgb a, b, c;
  std::uint32_t seed;
};

/// Painted surface: nearly uniform (low texture), a faint large-scale mottle; optional baseboard.
Rgb plain_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  [[maybe_unused]] const auto& [a, b, c, seed] = paint;
  float k = 1.0f + 0.10f * noise(s, t, 0.7f, seed, fp) + 0.05f * noise(s, t, 6.0f, seed + 1, fp) +
            0.04f * noise(s, t, 40.0f, seed + 2, fp);
  Rgb col = a * k;
  if (m.scale2 > 0) col = mix(col, b, inside(t, -1.0f, m.scale2, fp));
  return col;
}

/// Floor tiles of scale metres: a tint per tile, fine noise, grout lines in c.
Rgb tiles_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  const auto& [a, b, c, seed] = paint;
  const float size = m.scale;
  const int ix = static_cast<int>(std::floor(s / size)), iy = static_cast<int>(std::floor(t / size));
  float tint = lattice(ix, iy, seed);
  tint = tint + (0.5f - tint) * smoothstep(0.25f * size, 0.5f * size, fp);
  Rgb col = mix(a, b, tint * 0.7f);
  col = col * (1.0f + 0.30f * noise(s, t, 25.0f, seed + 1, fp) + 0.25f * noise(s, t, 70.0f, seed + 2, fp) +
               0.10f * noise(s, t, 3.0f, seed + 3, fp));
  const float g = std::max(lines(s, size, 0.008f, fp), lines(t, size, 0.008f, fp));
  return mix(col, c, g);
}

/// Painted blocks of scale x scale2 metres, every other row offset by half a block; mortar in c.
Rgb blocks_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  [[maybe_unused]] const auto& [a, b, c, seed] = paint;
  const float w = m.scale, h = m.scale2 > 0 ? m.scale2 : 0.2f;
  const int row = static_cast<int>(std::floor(t / h));
  const float s2 = s + ((row & 1) ? 0.5f * w : 0.0f);
  const int col_i = static_cast<int>(std::floor(s2 / w));
  float tint = lattice(col_i, row, seed) - 0.5f;
  tint *= 1.0f - smoothstep(0.25f * h, 0.5f * h, fp);
  Rgb col = a * (1.0f + 0.12f * tint + 0.22f * noise(s, t, 18.0f, seed + 1, fp) +
                 0.15f * noise(s, t, 55.0f, seed + 2, fp));
  const float g = std::max(lines(t, h, 0.012f, fp), lines(s2, w, 0.012f, fp));
  return mix(col, c, g);
}

/// Ceiling tiles of scale metres: fine speckle, a grid of b.
Rgb ceiling_tiles_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  [[maybe_unused]] const auto& [a, b, c, seed] = paint;
  const float size = m.scale;
  Rgb col = a * (1.0f + 0.25f * noise(s, t, 35.0f, seed, fp) + 0.2f * noise(s, t, 90.0f, seed + 1, fp) +
                 0.06f * noise(s, t, 1.5f, seed + 2, fp));
  const float g = std::max(lines(s, size, 0.025f, fp), lines(t, size, 0.025f, fp));
  return mix(col, b, g);
}

/// Carpet: mottled between a and b, a faint checker of scale metres.
Rgb carpet_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  [[maybe_unused]] const auto& [a, b, c, seed] = paint;
  const float size = m.scale;
  const int ix = static_cast<int>(std::floor(s / size)), iy = static_cast<int>(std::floor(t / size));
  float tint = ((ix + iy) & 1) ? 0.05f : -0.05f;
  tint *= 1.0f - smoothstep(0.25f * size, 0.5f * size, fp);
  Rgb col = mix(a, b, 0.5f + 0.9f * noise(s, t, 2.5f, seed, fp));
  return col * (1.0f + tint + 0.35f * noise(s, t, 22.0f, seed + 1, fp) + 0.3f * noise(s, t, 60.0f, seed + 2, fp));
}

/// Wood grain: warped stripes between a and b.
Rgb wood_albedo(const Material& /* no size: the grain is in metres */, const Paint& paint, float s, float t, float fp) {
  [[maybe_unused]] const auto& [a, b, c, seed] = paint;
  const float warp = 2.0f * vnoise(s * 1.3f, t * 4.0f, seed);
  const float f = 22.0f;
  const float grain = 0.5f + 0.5f * std::sin(6.2831853f * (t * f + warp)) * fade(f, fp);
  Rgb col = mix(a, b, 0.25f + 0.5f * grain);
  return col * (1.0f + 0.2f * noise(s, t, 30.0f, seed + 1, fp));
}

/// A poster of scale x scale2 metres: white margin, a title bar, a grid of coloured blocks and text.
Rgb poster_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  [[maybe_unused]] const auto& [a, b, c, seed] = paint;
  const float W = m.scale, H = m.scale2;
  const Rgb paper = a;
  const float margin = 0.03f;
  Rgb col = paper * (1.0f + 0.04f * noise(s, t, 8.0f, seed, fp));
  const float title_t0 = H * 0.80f;
  const Rgb title = palette(hash32(seed * 3 + 1), true);
  col = mix(col, title, inside2(s, t, margin, W - margin, title_t0, H - margin, fp));
  col = mix(col, paper, text(s, t, margin + 0.03f, W - margin - 0.03f, title_t0 + 0.02f, H - margin - 0.02f,
                             0.05f, seed + 5, fp) * 0.9f);
  const int nx = 2 + static_cast<int>(hash32(seed) % 2), ny = 3;
  const float cw = (W - 2 * margin) / nx, ch = (title_t0 - 2 * margin) / ny;
  const float u = (s - margin) / cw, v = (t - margin) / ch;
  if (u >= 0 && v >= 0 && u < nx && v < ny) {
    const int cx = static_cast<int>(u), cy = static_cast<int>(v);
    const std::uint32_t h = hash2i(cx, cy, seed);
    const float x0 = margin + cx * cw + 0.015f, x1 = margin + (cx + 1) * cw - 0.015f;
    const float y0 = margin + cy * ch + 0.015f, y1 = margin + (cy + 1) * ch - 0.015f;
    const int kind = static_cast<int>(h % 3);
    if (kind == 0) {  // picture: a coloured block with blobs
      const Rgb base = palette(h >> 3, true);
      const Rgb blob = palette(h >> 7, true);
      const float n = vnoise(s * 9.0f, t * 9.0f, h);
      Rgb pic = mix(base, blob, smoothstep(0.45f, 0.55f, n) * fade(9.0f, fp));
      const float f = 1.0f - smoothstep(0.25f * ch, 0.5f * ch, fp);
      col = mix(col, mix(palette_mean(true), pic, f), inside2(s, t, x0, x1, y0, y1, fp));
    } else if (kind == 1) {  // text
      col = mix(col, c, 0.85f * text(s, t, x0, x1, y0, y1, 0.022f, h, fp));
    } else {  // a chart: bars
      const Rgb bar = palette(h >> 5, true);
      const int nb = 4;
      const float bw = (x1 - x0) / nb;
      const int bi = std::clamp(static_cast<int>((s - x0) / bw), 0, nb - 1);
      const float top = y0 + (y1 - y0) * (0.25f + 0.7f * lattice(bi, 3, h));
      col = mix(col, bar, inside2(s, t, x0 + bi * bw + 0.2f * bw, x0 + (bi + 1) * bw - 0.2f * bw, y0, top, fp));
    }
  }
  return col;
}

/// A door of scale x scale2 metres: frame, panel (wood or paint), handle, kick plate, sign.
Rgb door_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  const auto& [a, b, c, seed] = paint;
  const float W = m.scale, H = m.scale2;
  Rgb panel = (seed & 1) ? mix(a, a * 0.75f, 0.5f + 0.5f * std::sin(6.2831853f * (s * 14.0f + 2.0f * vnoise(s * 2.0f, t * 0.5f, seed))) * fade(14.0f, fp))
                         : a * (1.0f + 0.06f * noise(s, t, 3.0f, seed, fp));
  Rgb col = mix(b, panel, inside2(s, t, 0.06f, W - 0.06f, 0.0f, H - 0.06f, fp));
  col = mix(col, c, inside2(s, t, 0.08f, W - 0.08f, 0.0f, 0.2f, fp) * 0.8f);
  col = mix(col, c, inside2(s, t, W - 0.17f, W - 0.07f, 0.98f, 1.04f, fp));
  const Rgb sign{0.8f, 0.8f, 0.8f};
  col = mix(col, sign, inside2(s, t, 0.5f * W - 0.11f, 0.5f * W + 0.11f, 1.48f, 1.6f, fp));
  col = mix(col, Rgb{0.02f, 0.02f, 0.02f}, 0.9f * text(s, t, 0.5f * W - 0.09f, 0.5f * W + 0.09f, 1.5f, 1.58f, 0.025f, seed, fp));
  return col;
}

/// Front of a bookshelf (scale x scale2): wood frame and shelves, rows of coloured spines.
Rgb books_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  [[maybe_unused]] const auto& [a, b, c, seed] = paint;
  const float W = m.scale, H = m.scale2;
  const int shelves = std::max(2, static_cast<int>(std::round(H / 0.38f)));
  const float gap = (H - 0.05f) / shelves;
  const float frame = 0.025f;
  const float in_frame = inside2(s, t, frame, W - frame, frame, H - frame, fp);
  const int level = std::clamp(static_cast<int>((t - frame) / gap), 0, shelves - 1);
  const float t0 = frame + level * gap + 0.02f;  // top of this shelf board
  const float rel = t - t0;
  const float spine = 0.035f;
  const int bi = static_cast<int>(std::floor(s / spine));
  const std::uint32_t h = hash2i(bi, level, seed);
  const bool empty = (h % 11) == 0 || (hash2i(bi / 6, level, seed + 9) % 7) == 0;
  const float book_h = (0.65f + 0.3f * static_cast<float>((h >> 4) % 8) / 7.0f) * (gap - 0.02f);
  Rgb book = palette(h >> 8, false);
  book = mix(book, Rgb{0.75f, 0.72f, 0.6f}, inside(rel, book_h * 0.6f, book_h * 0.7f, fp) * 0.6f);
  const float edge = lines(s, spine, 0.004f, fp);
  book = mix(book, c, edge * 0.8f);
  const float f = 1.0f - smoothstep(0.5f * spine, 1.0f * spine, fp);  // cells, not lines: fade late
  book = mix(palette_mean(false), book, f);
  Rgb col = c;  // shadow inside the shelf
  if (!empty) col = mix(col, book, inside(rel, 0.0f, book_h, fp));
  col = mix(col, a, 1.0f - inside(rel, 0.0f, gap - 0.02f, fp));  // shelf boards
  return mix(a, col, in_frame);
}

/// Cardboard of height scale2: noise, a tape band of b, a printed label of c.
Rgb cardboard_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  const auto& [a, b, c, seed] = paint;
  Rgb col = a * (1.0f + 0.15f * noise(s, t, 9.0f, seed, fp) + 0.12f * noise(s, t, 45.0f, seed + 1, fp));
  const float H = m.scale2 > 0 ? m.scale2 : 0.4f;
  col = mix(col, b, inside(t, 0.5f * H - 0.025f, 0.5f * H + 0.025f, fp));
  col = mix(col, c, 0.85f * text(s, t, 0.05f, 0.2f, 0.06f, 0.12f, 0.02f, seed, fp));
  return col;
}

/// A whiteboard of scale x scale2 metres: four ink strokes, a frame of b.
Rgb whiteboard_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  const auto& [a, b, c, seed] = paint;
  const float W = m.scale, H = m.scale2;
  Rgb col = a * (1.0f + 0.05f * noise(s, t, 1.5f, seed, fp));
  for (int k = 0; k < 4; ++k) {
    const std::uint32_t h = hash2i(k, 1, seed);
    const float tk = H * (0.25f + 0.17f * k);
    const float s0 = W * (0.08f + 0.2f * lattice(k, 2, seed));
    const float len = W * (0.25f + 0.4f * lattice(k, 3, seed));
    const float curve = tk + 0.03f * std::sin(s * (18.0f + 5.0f * k) + static_cast<float>(k));
    const float stroke = inside(t, curve - 0.004f, curve + 0.004f, fp) * inside(s, s0, s0 + len, fp);
    const Rgb ink = (h % 3 == 0) ? Rgb{0.35f, 0.02f, 0.02f} : (h % 3 == 1) ? Rgb{0.02f, 0.05f, 0.3f} : c;
    col = mix(col, ink, stroke * 0.9f);
  }
  return mix(b, col, inside2(s, t, 0.03f, W - 0.03f, 0.03f, H - 0.03f, fp));
}

/// A ceiling light panel of scale x scale2 metres: a in a frame of b.
Rgb light_panel_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  [[maybe_unused]] const auto& [a, b, c, seed] = paint;
  const float W = m.scale, H = m.scale2;
  return mix(b, a, inside2(s, t, 0.03f, W - 0.03f, 0.03f, H - 0.03f, fp));
}

/// A checkerboard of period scale metres in both directions.
Rgb checker_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  [[maybe_unused]] const auto& [a, b, c, seed] = paint;
  const float v = square(s, m.scale, fp) * square(t, m.scale, fp);
  return mix(b, a, 0.5f + 0.5f * v);
}

/// Fabric: a, or stripes of a and b of period scale2, with weave noise.
Rgb fabric_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  [[maybe_unused]] const auto& [a, b, c, seed] = paint;
  Rgb col = a;
  if (m.scale2 > 0) col = mix(a, b, 0.5f + 0.5f * square(t, m.scale2, fp));
  return col * (1.0f + 0.25f * noise(s, t, 40.0f, seed, fp) + 0.1f * noise(s, t, 6.0f, seed + 1, fp));
}

/// A monitor of scale x scale2 metres: a window of b with text, a bezel of c.
Rgb screen_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  const auto& [a, b, c, seed] = paint;
  const float W = m.scale, H = m.scale2;
  Rgb col = a;
  col = mix(col, b, inside2(s, t, 0.2f * W, 0.75f * W, 0.3f * H, 0.85f * H, fp));
  col = mix(col, Rgb{0.02f, 0.02f, 0.03f}, 0.8f * text(s, t, 0.23f * W, 0.7f * W, 0.35f * H, 0.75f * H, 0.018f, seed, fp));
  return mix(c, col, inside2(s, t, 0.02f, W - 0.02f, 0.02f, H - 0.02f, fp));
}

/// Cabinet front: drawers of scale metres high over a width of scale2, gaps and handles.
Rgb drawers_albedo(const Material& m, const Paint& paint, float s, float t, float fp) {
  const auto& [a, b, c, seed] = paint;
  const float h = m.scale, W = m.scale2 > 0 ? m.scale2 : 0.5f;
  Rgb col = a * (1.0f + 0.05f * noise(s, t, 4.0f, seed, fp) + 0.05f * noise(s, t, 40.0f, seed + 1, fp));
  col = mix(col, c, lines(t, h, 0.006f, fp));
  const float tt = t - h * std::floor(t / h);
  col = mix(col, b, inside2(s, tt, 0.5f * W - 0.07f, 0.5f * W + 0.07f, 0.72f * h, 0.72f * h + 0.025f, fp));
  return col;
}

}  // namespace

Rgb albedo(const Material& m, float s, float t, float fp) {
  const Paint paint{rgb(m.a), rgb(m.b), rgb(m.c), m.seed};
  switch (m.kind) {
    case Material::Plain:
      return plain_albedo(m, paint, s, t, fp);
    case Material::Tiles:
      return tiles_albedo(m, paint, s, t, fp);
    case Material::Blocks:
      return blocks_albedo(m, paint, s, t, fp);
    case Material::CeilingTiles:
      return ceiling_tiles_albedo(m, paint, s, t, fp);
    case Material::Carpet:
      return carpet_albedo(m, paint, s, t, fp);
    case Material::Wood:
      return wood_albedo(m, paint, s, t, fp);
    case Material::Poster:
      return poster_albedo(m, paint, s, t, fp);
    case Material::Door:
      return door_albedo(m, paint, s, t, fp);
    case Material::Books:
      return books_albedo(m, paint, s, t, fp);
    case Material::Cardboard:
      return cardboard_albedo(m, paint, s, t, fp);
    case Material::Whiteboard:
      return whiteboard_albedo(m, paint, s, t, fp);
    case Material::Light:
      return light_panel_albedo(m, paint, s, t, fp);
    case Material::Checker:
      return checker_albedo(m, paint, s, t, fp);
    case Material::Fabric:
      return fabric_albedo(m, paint, s, t, fp);
    case Material::Screen:
      return screen_albedo(m, paint, s, t, fp);
    case Material::Drawers:
      return drawers_albedo(m, paint, s, t, fp);
  }
  return rgb(m.a);
}

}  // namespace smseg::synth::detail
