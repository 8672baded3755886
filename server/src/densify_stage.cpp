#include "densemap/server/densify_stage.h"

#include <algorithm>
#include <stdexcept>

#include <spdlog/spdlog.h>

#include "densemap/densify/iln_plugin.h"
#include "densemap/densify/model_files.h"

namespace densemap::server {

io::LidarGeometry densifiedGeometry(const io::LidarGeometry& input, int rows, int columns) {
  io::LidarGeometry out = input;
  out.rows = rows;
  out.columns = columns > 0 ? columns : input.columns;
  const double in_step = input.rows > 1 ? (input.fov_up_deg - input.fov_down_deg) / (input.rows - 1) : 0.0;
  const double out_step = in_step * input.rows / std::max(1, rows);
  out.fov_down_deg = input.fov_up_deg - out_step * (rows - 1);
  return out;
}

std::unique_ptr<densify::RangeUpsampler> makeUpsampler(const DensifyOptions& o) {
  if (o.method == "bilinear") return std::make_unique<densify::BilinearUpsampler>();
  if (o.method != "iln")
    throw std::invalid_argument("densify method must be none, iln or bilinear, not " + o.method);
  const std::string path = o.weights.empty() ? densify::shippedWeights() : o.weights;
  return densify::loadIlnUpsampler(path, o.threads);  // libtorch is loaded here, only when ILN is asked for
}

DensifyStage::DensifyStage(const DensifyOptions& options, std::unique_ptr<densify::RangeUpsampler> upsampler)
    : options_(options), upsampler_(std::move(upsampler)) {}

bool DensifyStage::applies(const ScanJob& job) const {
  if (!job.scan.lidar) return false;
  if (!options_.robots.empty())
    return std::find(options_.robots.begin(), options_.robots.end(), job.robot_id) != options_.robots.end();
  return options_.input_rows == 0 || job.scan.lidar->rows == options_.input_rows;
}

StageResult DensifyStage::process(ScanJob& job) {
  if (!applies(job) || job.scan.lidar->rows >= options_.target_rows) return StageResult::passThrough();
  const io::LidarGeometry& in = *job.scan.lidar;
  const io::LidarGeometry out = densifiedGeometry(in, options_.target_rows, options_.target_columns);
  const auto image = densify::project(job.scan.sensorPoints(), in);
  job.scan.points = densify::toPoints(upsampler_->upsample(image, out));
  job.scan.frame = io::PointFrame::kSensor;
  job.scan.lidar = out;
  return {};
}

}  // namespace densemap::server
