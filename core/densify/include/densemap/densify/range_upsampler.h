// Range-image super-resolution (Ch. 4): predict the range of every pixel of a denser beam layout from a
// sparse range image. Interpolating methods share the query geometry of Eq. 4.2/4.3: each output pixel
// falls between 4 input pixels and its range is a weighted sum of their measured ranges.
#pragma once

#include <array>
#include <memory>
#include <string>
#include <vector>

#include "densemap/densify/range_image.h"

namespace densemap::densify {

/// One output pixel's 4 input neighbours (top-left, top-right, bottom-left, bottom-right) and its offset
/// from each neighbour's centre in input-pixel units (row, column), the Delta q_t of Fig. 4.4(a).
struct QueryNeighbours {
  std::array<int, 4> index{};  ///< row * columns + column in the input image
  std::array<std::array<float, 2>, 4> offset{};
  float row_fraction = 0;     ///< position between the upper and lower neighbour rows, [0, 1]
  float column_fraction = 0;  ///< position between the left and right neighbour columns, [0, 1)
};

/// The neighbours of every pixel of `output` (row-major) on `input`'s grid. Rows above the first or below
/// the last input beam clamp to it; columns wrap around the 360-degree sweep.
std::vector<QueryNeighbours> queryNeighbours(const LidarGeometry& input, const LidarGeometry& output);

/// A sparse input image and a denser target image of the same scene and pose (training and evaluation).
struct RangeImagePair {
  RangeImage input;
  RangeImage target;
};

class RangeUpsampler {
 public:
  virtual ~RangeUpsampler() = default;
  virtual std::string name() const = 0;
  /// The range image on `output`'s beam layout predicted from `input` (0 where nothing can be predicted).
  virtual RangeImage upsample(const RangeImage& input, const LidarGeometry& output) = 0;
};

/// Bilinear interpolation of the 4 neighbours (the Sec. 4.4.2 baseline). Neighbours without a return are
/// left out and the remaining weights renormalised; with none, the pixel stays empty.
class BilinearUpsampler : public RangeUpsampler {
 public:
  std::string name() const override { return "bilinear"; }
  RangeImage upsample(const RangeImage& input, const LidarGeometry& output) override;
};

/// The nearest of the 4 neighbours that has a return.
class NearestUpsampler : public RangeUpsampler {
 public:
  std::string name() const override { return "nearest"; }
  RangeImage upsample(const RangeImage& input, const LidarGeometry& output) override;
};

}  // namespace densemap::densify
