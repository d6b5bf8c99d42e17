#pragma once
// Synthetic frames for tests and benchmarks of the forest (no dependency on features/): a room-like
// layout per frame (ceiling / wall / floor bands with wavy, frame-dependent boundaries and a box of a
// fourth class), smooth random feature fields whose level depends on the class, a greyscale image,
// and the summed-area tables. Owns its buffers; `data` views them.

#include <cstdint>
#include <vector>

#include "smseg/forest/data.hpp"

namespace smseg::forest {

struct SyntheticOptions {
  int width = 320, height = 240;
  int frames = 11;
  int features = 6;
  int classes = 4;          ///< 1..4 geometric classes (ceiling, wall, floor, box)
  std::uint64_t seed = 1;             ///< frames (geometry, noise)
  std::uint64_t world_seed = 12345;   ///< class levels of the features, shared by all seeds
  double signal = 1.0;      ///< class-dependent level of each feature (0: features carry no label)
  double noise = 1.0;       ///< amplitude of the smooth random fields
  bool integer_features = false;  ///< round feature values to integers (exact window sums)
  bool random_labels = false;     ///< labels i.i.d. uniform per pixel (features then unrelated)
  int void_border = 0;      ///< pixels this close to the image border are void
};

struct SyntheticData {
  Dataset data;
  std::vector<std::vector<double>> images;  ///< [frame * F + f]: height x width feature values
  std::vector<std::vector<double>> sats;    ///< [frame * F + f]: (height+1) x (width+1)
  std::vector<std::vector<std::uint8_t>> gray, labels;

  SyntheticData() = default;
  SyntheticData(const SyntheticData&) = delete;
  SyntheticData& operator=(const SyntheticData&) = delete;
  SyntheticData(SyntheticData&&) = default;  // vectors keep their buffers: views stay valid
  SyntheticData& operator=(SyntheticData&&) = default;
};

SyntheticData make_synthetic(const SyntheticOptions& opts);

/// Summed-area table of a width x height image into sat ((height+1) x (width+1)).
void summed_area_table(const double* image, int width, int height, double* sat);

}  // namespace smseg::forest
