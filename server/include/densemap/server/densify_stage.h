// ILN densify (Ch. 4) as the pipeline stage before the occupancy update: sparse scans (by their LiDAR's
// beam count, or by robot) are re-sampled to a denser beam layout, so a 16-beam robot maps like a 64-beam
// one; the super rays and culling region keep the denser update fast (Fig. 4.10).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "densemap/densify/range_upsampler.h"
#include "densemap/server/pipeline_stage.h"

namespace densemap::server {

struct DensifyOptions {
  std::string method = "none";  ///< none, iln (the trained network) or bilinear (the baseline)
  std::string weights;          ///< ILN weights; empty: the shipped compact model (models/iln/iln_compact.pt)
  /// Scans from a LiDAR with this many beams are densified (0: any scan that carries its geometry)...
  int input_rows = 16;
  /// ...or, when not empty, exactly the scans of these robots (they must carry their LiDAR geometry).
  std::vector<std::string> robots;
  /// Output beams and columns (0: the input's columns). Beam spacing is the input's divided by
  /// rows / input rows, from the same top beam, so every input beam is an output beam (16 -> 64 reproduces
  /// the KITTI HDL-64E layout from its every 4th beam).
  int target_rows = 64;
  int target_columns = 0;
  int threads = 2;  ///< libtorch and inference threads
};

/// The output layout for an input layout (see DensifyOptions::target_rows).
io::LidarGeometry densifiedGeometry(const io::LidarGeometry& input, int rows, int columns);

/// Builds the upsampler an options set names; throws std::runtime_error naming a missing weights file.
std::unique_ptr<densify::RangeUpsampler> makeUpsampler(const DensifyOptions& options);

class DensifyStage : public PipelineStage {
 public:
  DensifyStage(const DensifyOptions& options, std::unique_ptr<densify::RangeUpsampler> upsampler);
  std::string name() const override { return "densify"; }
  StageResult process(ScanJob& job) override;
  /// True when the options select this scan.
  bool applies(const ScanJob& job) const;

 private:
  DensifyOptions options_;
  std::unique_ptr<densify::RangeUpsampler> upsampler_;
};

}  // namespace densemap::server
