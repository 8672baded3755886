// Training and test pairs for range-image super-resolution (Sec. 4.4.1 and 4.4.5): a sparse input image
// and the dense target of the same scan, from the built-in simulator or from real 64-beam scans.
#pragma once

#include <cstdint>
#include <vector>

#include "densemap/densify/range_upsampler.h"
#include "densemap/io/lidar_simulator.h"
#include "densemap/io/spinning_lidar_model.h"

namespace densemap::densify {

/// A real scan's pair: its points projected on `dense` (the target) and every `beam_step`-th beam of that
/// image (the input, e.g. 16 of 64 beams).
RangeImagePair exampleFromScan(const io::Scan& scan, const LidarGeometry& dense, int beam_step);

/// Simulator pairs as the CARLA protocol: each pose rendered as every `beam_step`-th beam of `input_base`
/// (the input) and on `target` (e.g. 64x1024 or 128x2048), the same scene and pose. `scene_seed` picks the
/// procedural scene, so training and test scenes differ.
std::vector<RangeImagePair> simulatorExamples(std::uint64_t scene_seed, int scans,
                                              const LidarGeometry& input_base, int beam_step,
                                              const LidarGeometry& target);

/// Simulator pairs made the way real scans are (exampleFromScan): a sensor whose beams do not sit exactly on
/// the image grid (field of view shifted by up to a third of a beam, per scene), 2048 returns per beam and
/// 2 cm range noise, projected on `dense` (collisions and empty pixels as in KITTI's projection); the input
/// is every `beam_step`-th row of that image. Training on these closes most of the gap between clean
/// renders and real range images.
std::vector<RangeImagePair> sensorLikeSimulatorExamples(std::uint64_t scene_seed, int scans,
                                                        const LidarGeometry& dense, int beam_step);

/// Simulator pairs from a real sensor's model (its beam table, one unit's calibration offsets and tilt,
/// range noise, lost returns, porous foliage) in street scenes with pavements and hedges, projected on
/// `dense` the way real scans are; the input is every `beam_step`-th row of that image. `scene_seed` picks
/// the scene and the unit.
std::vector<RangeImagePair> sensorModelSimulatorExamples(std::uint64_t scene_seed, int scans,
                                                         const io::SpinningLidarModel& model,
                                                         const LidarGeometry& dense, int beam_step);

/// The range-image grid real scans of this model are projected on: KITTI's 64 x 1024 (+2 to -24.9
/// degrees) for the HDL-64E, otherwise the model's beams over its own table's extremes.
LidarGeometry imageGridOf(const io::SpinningLidarModel& model, int columns = 1024);

/// Point-reconstruction and range accuracy of a predicted image (Sec. 4.4.2).
struct ReconstructionScore {
  double mae_m = 0;        ///< mean |predicted - target| range over pixels both have
  std::size_t pixels = 0;  ///< pixels in the MAE
  double iou = 0, precision = 0, recall = 0, f1 = 0;  ///< of occupied 0.1 m voxels vs the real points
};
ReconstructionScore scoreReconstruction(const RangeImage& predicted, const RangeImage& target,
                                        const std::vector<Vec3f>& target_points, double voxel_size = 0.1);

}  // namespace densemap::densify
