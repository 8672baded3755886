// LiDAR range images (Ch. 4, Sec. 4.2): a scan seen as ranges on its beam layout's pixel grid, and back.
#pragma once

#include <vector>

#include "densemap/io/scan.h"

namespace densemap::densify {

using io::LidarGeometry;
using io::Vec3f;

/// rows x columns ranges in metres, row-major; 0 marks a pixel with no return. Pixel (i, j) is the laser
/// direction of io::LidarGeometry (row 0 = top beam, columns sweep azimuth from +fov_h/2 downward).
struct RangeImage {
  LidarGeometry geometry;
  std::vector<float> range;

  RangeImage() = default;
  explicit RangeImage(const LidarGeometry& g)
      : geometry(g), range(static_cast<std::size_t>(g.rows) * static_cast<std::size_t>(g.columns), 0.0f) {}
  int rows() const { return geometry.rows; }
  int columns() const { return geometry.columns; }
  float& at(int row, int column) { return range[index(row, column)]; }
  float at(int row, int column) const { return range[index(row, column)]; }
  std::size_t validCount() const;

 private:
  std::size_t index(int row, int column) const {
    return static_cast<std::size_t>(row) * static_cast<std::size_t>(geometry.columns) +
           static_cast<std::size_t>(column);
  }
};

/// Where a laser direction falls on a geometry's pixel grid, in pixel units: row = 0 at the top beam and
/// rows - 1 at the bottom one, column = 0 at the first column's centre (it wraps every `columns`).
struct PixelCoordinate {
  double row = 0;
  double column = 0;
};
PixelCoordinate pixelOf(const LidarGeometry& g, double elevation_deg, double azimuth_deg);
/// The laser direction (elevation, azimuth in degrees) of pixel (row, column) of a geometry.
void directionOf(const LidarGeometry& g, double row, double column, double& elevation_deg,
                 double& azimuth_deg);

/// Projects sensor-frame points to their nearest pixels; where several fall on one pixel the nearest range
/// wins (as the first return of the beam would). Points outside the vertical field of view are left out.
RangeImage project(const std::vector<Vec3f>& sensor_points, const LidarGeometry& g);

/// The sensor-frame points of every pixel with a return, each along its pixel's direction.
std::vector<Vec3f> toPoints(const RangeImage& image);

/// The geometry of every `step`-th beam of g from the top (64 -> 16 beams with step 4): the kept beams
/// keep their elevations exactly.
LidarGeometry everyNthBeam(const LidarGeometry& g, int step);
/// Keeps every `step`-th row of an image from the top (the sparse input of Sec. 4.4.5).
RangeImage keepEveryNthRow(const RangeImage& image, int step);

}  // namespace densemap::densify
