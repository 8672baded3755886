#include "densemap/densify/densify_dataset.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_set>

namespace densemap::densify {

RangeImagePair exampleFromScan(const io::Scan& scan, const LidarGeometry& dense, int beam_step) {
  RangeImagePair ex;
  ex.target = project(scan.sensorPoints(), dense);
  ex.input = keepEveryNthRow(ex.target, beam_step);
  return ex;
}

namespace {
/// The simulator driving a procedural scene's road, `scans` poses spread over its whole length (so the
/// examples differ); `scene_seed` seeds the scene and the noise.
io::LidarSimulatorOptions roadOptions(std::uint64_t scene_seed, int scans) {
  io::LidarSimulatorOptions o;
  o.scans = scans;
  o.scene.seed = scene_seed;
  o.seed = scene_seed;
  o.speed = std::max(1.0, (o.scene.length - 30.0) / std::max(1, scans));
  o.start_x = -o.scene.length / 2 + 15.0;
  return o;
}
}  // namespace

std::vector<RangeImagePair> simulatorExamples(std::uint64_t scene_seed, int scans,
                                              const LidarGeometry& input_base, int beam_step,
                                              const LidarGeometry& target) {
  const io::LidarSimulator sim(roadOptions(scene_seed, scans));
  const LidarGeometry sparse = everyNthBeam(input_base, beam_step);
  std::vector<RangeImagePair> out;
  for (int i = 0; i < scans; ++i) {
    RangeImagePair ex;
    ex.input = project(sim.render(static_cast<std::size_t>(i), sparse).sensorPoints(), sparse);
    ex.target = project(sim.render(static_cast<std::size_t>(i), target).sensorPoints(), target);
    out.push_back(std::move(ex));
  }
  return out;
}

std::vector<RangeImagePair> sensorLikeSimulatorExamples(std::uint64_t scene_seed, int scans,
                                                        const LidarGeometry& dense, int beam_step) {
  io::LidarSimulatorOptions o = roadOptions(scene_seed, scans);
  o.range_noise = 0.02;
  const io::LidarSimulator sim(o);
  std::mt19937_64 rng(scene_seed);
  const double row_step = (dense.fov_up_deg - dense.fov_down_deg) / std::max(1, dense.rows - 1);
  std::uniform_real_distribution<double> shift(-row_step / 3, row_step / 3);
  LidarGeometry sensor = dense;
  sensor.columns = 2 * dense.columns;
  sensor.fov_up_deg += shift(rng);
  sensor.fov_down_deg += shift(rng);
  std::vector<RangeImagePair> out;
  for (int i = 0; i < scans; ++i) {
    RangeImagePair ex;
    ex.target = project(sim.render(static_cast<std::size_t>(i), sensor).sensorPoints(), dense);
    ex.input = keepEveryNthRow(ex.target, beam_step);
    out.push_back(std::move(ex));
  }
  return out;
}

std::vector<RangeImagePair> sensorModelSimulatorExamples(std::uint64_t scene_seed, int scans,
                                                         const io::SpinningLidarModel& model,
                                                         const LidarGeometry& dense, int beam_step) {
  io::LidarSimulatorOptions o = roadOptions(scene_seed, scans);
  o.scene.pavements = true;
  o.scene.hedges = 8;
  o.scene.boxes = 20;
  o.max_range = model.max_range_m;
  const io::LidarSimulator sim(o);
  const io::SpinningLidarModel unit = model.unit(scene_seed);
  std::vector<RangeImagePair> out;
  for (int i = 0; i < scans; ++i) {
    RangeImagePair ex;
    ex.target = project(sim.render(static_cast<std::size_t>(i), unit).sensorPoints(), dense);
    ex.input = keepEveryNthRow(ex.target, beam_step);
    out.push_back(std::move(ex));
  }
  return out;
}

LidarGeometry imageGridOf(const io::SpinningLidarModel& model, int columns) {
  if (model.name == "hdl64e") return LidarGeometry{64, columns, 2.0, -24.9, 360.0};
  const auto [lo, hi] = std::minmax_element(model.elevation_deg.begin(), model.elevation_deg.end());
  return LidarGeometry{model.beams(), columns, *hi, *lo, 360.0};
}

namespace {
struct KeyHash {
  std::size_t operator()(const std::array<std::int32_t, 3>& k) const {
    return (static_cast<std::size_t>(static_cast<std::uint32_t>(k[0])) * 73856093u) ^
           (static_cast<std::size_t>(static_cast<std::uint32_t>(k[1])) * 19349663u) ^
           (static_cast<std::size_t>(static_cast<std::uint32_t>(k[2])) * 83492791u);
  }
};
using VoxelSet = std::unordered_set<std::array<std::int32_t, 3>, KeyHash>;
VoxelSet voxels(const std::vector<Vec3f>& points, double size) {
  VoxelSet s;
  s.reserve(points.size());
  for (const Vec3f& p : points)
    s.insert({static_cast<std::int32_t>(std::floor(p.x() / size)),
              static_cast<std::int32_t>(std::floor(p.y() / size)),
              static_cast<std::int32_t>(std::floor(p.z() / size))});
  return s;
}
}  // namespace

ReconstructionScore scoreReconstruction(const RangeImage& predicted, const RangeImage& target,
                                        const std::vector<Vec3f>& target_points, double voxel_size) {
  ReconstructionScore s;
  double err = 0;
  for (std::size_t k = 0; k < predicted.range.size() && k < target.range.size(); ++k) {
    if (predicted.range[k] > 0.0f && target.range[k] > 0.0f) {
      err += std::abs(static_cast<double>(predicted.range[k]) - target.range[k]);
      ++s.pixels;
    }
  }
  s.mae_m = s.pixels ? err / static_cast<double>(s.pixels) : 0.0;
  const VoxelSet p = voxels(toPoints(predicted), voxel_size), t = voxels(target_points, voxel_size);
  std::size_t both = 0;
  for (const auto& k : p) both += t.count(k);
  const std::size_t either = p.size() + t.size() - both;
  s.iou = either ? static_cast<double>(both) / static_cast<double>(either) : 0.0;
  s.precision = p.empty() ? 0.0 : static_cast<double>(both) / static_cast<double>(p.size());
  s.recall = t.empty() ? 0.0 : static_cast<double>(both) / static_cast<double>(t.size());
  s.f1 = s.precision + s.recall > 0 ? 2 * s.precision * s.recall / (s.precision + s.recall) : 0.0;
  return s;
}

}  // namespace densemap::densify
