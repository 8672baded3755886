// ILN densify (Ch. 4) as the pipeline stage before the occupancy update: sparse scans (by their LiDAR's
// beam count, or by robot) are re-sampled to a denser beam layout, so a 16-beam robot maps like a 64-beam
// one; the super rays and culling region keep the denser update fast (Fig. 4.10).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "densemap/densify/range_upsampler.h"
#include "densemap/server/pipeline_stage.h"
#include "densemap/server/stage_options.h"

namespace densemap::server {

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
