#include "densemap/densify/range_upsampler.h"

#include <algorithm>
#include <cmath>

namespace densemap::densify {

std::vector<QueryNeighbours> queryNeighbours(const LidarGeometry& input, const LidarGeometry& output) {
  std::vector<QueryNeighbours> out(static_cast<std::size_t>(output.rows) *
                                   static_cast<std::size_t>(output.columns));
  const int cols = input.columns;
  for (int i = 0; i < output.rows; ++i) {
    for (int j = 0; j < output.columns; ++j) {
      double el = 0, az = 0;
      directionOf(output, i, j, el, az);
      PixelCoordinate p = pixelOf(input, el, az);
      // A direction on an input pixel (up to rounding) is that pixel, not the far side of its neighbour.
      if (std::abs(p.row - std::round(p.row)) < 1e-6) p.row = std::round(p.row);
      if (std::abs(p.column - std::round(p.column)) < 1e-6) p.column = std::round(p.column);
      const double row = std::clamp(p.row, 0.0, static_cast<double>(input.rows - 1));
      const int r0 = std::min(static_cast<int>(std::floor(row)), std::max(0, input.rows - 2));
      const int r1 = std::min(r0 + 1, input.rows - 1);
      const double c_floor = std::floor(p.column);
      int c0 = static_cast<int>(c_floor) % cols;
      if (c0 < 0) c0 += cols;
      const int c1 = (c0 + 1) % cols;
      QueryNeighbours& q = out[static_cast<std::size_t>(i) * static_cast<std::size_t>(output.columns) +
                               static_cast<std::size_t>(j)];
      q.row_fraction = static_cast<float>(row - r0);
      q.column_fraction = static_cast<float>(p.column - c_floor);
      const int rs[4] = {r0, r0, r1, r1};
      const int cs[4] = {c0, c1, c0, c1};
      const double dr[4] = {row - r0, row - r0, row - r1, row - r1};
      const double dc[4] = {p.column - c_floor, p.column - c_floor - 1.0, p.column - c_floor,
                            p.column - c_floor - 1.0};
      for (int t = 0; t < 4; ++t) {
        q.index[static_cast<std::size_t>(t)] = rs[t] * cols + cs[t];
        q.offset[static_cast<std::size_t>(t)] = {static_cast<float>(dr[t]), static_cast<float>(dc[t])};
      }
    }
  }
  return out;
}

RangeImage BilinearUpsampler::upsample(const RangeImage& input, const LidarGeometry& output) {
  RangeImage out(output);
  const auto queries = queryNeighbours(input.geometry, output);
  for (std::size_t k = 0; k < queries.size(); ++k) {
    const QueryNeighbours& q = queries[k];
    const float a = q.row_fraction, b = q.column_fraction;
    const float w[4] = {(1 - a) * (1 - b), (1 - a) * b, a * (1 - b), a * b};
    float sum = 0, weight = 0;
    for (std::size_t t = 0; t < 4; ++t) {
      const float r = input.range[static_cast<std::size_t>(q.index[t])];
      if (r > 0.0f) {
        sum += w[t] * r;
        weight += w[t];
      }
    }
    out.range[k] = weight > 1e-6f ? sum / weight : 0.0f;
  }
  return out;
}

RangeImage NearestUpsampler::upsample(const RangeImage& input, const LidarGeometry& output) {
  RangeImage out(output);
  const auto queries = queryNeighbours(input.geometry, output);
  for (std::size_t k = 0; k < queries.size(); ++k) {
    const QueryNeighbours& q = queries[k];
    float best = 1e30f;
    for (std::size_t t = 0; t < 4; ++t) {
      const float r = input.range[static_cast<std::size_t>(q.index[t])];
      const float d = q.offset[t][0] * q.offset[t][0] + q.offset[t][1] * q.offset[t][1];
      if (r > 0.0f && d < best) {
        best = d;
        out.range[k] = r;
      }
    }
  }
  return out;
}

}  // namespace densemap::densify
