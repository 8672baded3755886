#include "densemap/densify/range_image.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace densemap::densify {

namespace {
constexpr double kDegPerRad = 180.0 / 3.14159265358979323846;

double rowStep(const LidarGeometry& g) {
  return g.rows > 1 ? (g.fov_up_deg - g.fov_down_deg) / (g.rows - 1) : 1.0;
}
}  // namespace

std::size_t RangeImage::validCount() const {
  return static_cast<std::size_t>(
      std::count_if(range.begin(), range.end(), [](float r) { return r > 0.0f; }));
}

PixelCoordinate pixelOf(const LidarGeometry& g, double elevation_deg, double azimuth_deg) {
  PixelCoordinate p;
  p.row = (g.fov_up_deg - elevation_deg) / rowStep(g);
  p.column = (g.fov_horizontal_deg / 2.0 - azimuth_deg) / g.fov_horizontal_deg * g.columns - 0.5;
  return p;
}

void directionOf(const LidarGeometry& g, double row, double column, double& elevation_deg,
                 double& azimuth_deg) {
  elevation_deg = g.fov_up_deg - row * rowStep(g);
  azimuth_deg = g.fov_horizontal_deg / 2.0 - (column + 0.5) * g.fov_horizontal_deg / g.columns;
}

RangeImage project(const std::vector<Vec3f>& sensor_points, const LidarGeometry& g) {
  if (g.rows < 1 || g.columns < 1) throw std::invalid_argument("range image geometry needs rows and columns");
  RangeImage image(g);
  for (const Vec3f& p : sensor_points) {
    const double x = p.x(), y = p.y(), z = p.z();
    const double r = std::sqrt(x * x + y * y + z * z);
    if (!(r > 0.0) || !std::isfinite(r)) continue;
    const PixelCoordinate px = pixelOf(g, std::asin(z / r) * kDegPerRad, std::atan2(y, x) * kDegPerRad);
    const long row = std::lround(px.row);
    if (row < 0 || row >= g.rows) continue;
    long col = std::lround(px.column) % g.columns;
    if (col < 0) col += g.columns;
    float& cell = image.at(static_cast<int>(row), static_cast<int>(col));
    if (cell == 0.0f || r < cell) cell = static_cast<float>(r);
  }
  return image;
}

std::vector<Vec3f> toPoints(const RangeImage& image) {
  std::vector<Vec3f> points;
  points.reserve(image.validCount());
  for (int i = 0; i < image.rows(); ++i) {
    for (int j = 0; j < image.columns(); ++j) {
      const float r = image.at(i, j);
      if (!(r > 0.0f)) continue;
      double el = 0, az = 0;
      directionOf(image.geometry, i, j, el, az);
      el /= kDegPerRad;
      az /= kDegPerRad;
      points.emplace_back(static_cast<float>(r * std::cos(el) * std::cos(az)),
                          static_cast<float>(r * std::cos(el) * std::sin(az)),
                          static_cast<float>(r * std::sin(el)));
    }
  }
  return points;
}

LidarGeometry everyNthBeam(const LidarGeometry& g, int step) {
  if (step < 1) throw std::invalid_argument("beam step must be >= 1");
  LidarGeometry out = g;
  out.rows = (g.rows - 1) / step + 1;
  out.fov_down_deg = g.fov_up_deg - (out.rows - 1) * step * rowStep(g);
  return out;
}

RangeImage keepEveryNthRow(const RangeImage& image, int step) {
  RangeImage out(everyNthBeam(image.geometry, step));
  for (int i = 0; i < out.rows(); ++i)
    std::copy_n(image.range.begin() + static_cast<std::ptrdiff_t>(i) * step * image.columns(),
                image.columns(), out.range.begin() + static_cast<std::ptrdiff_t>(i) * out.columns());
  return out;
}

}  // namespace densemap::densify
