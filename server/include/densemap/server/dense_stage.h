// The dense layer (AKIMap, or the BGK baseline) as a pipeline stage after the exact map. It may fall
// behind: its input queue drops the oldest waiting scans (counted in the stage statistics) so it always
// works on recent scans and never holds up the exact map.
#pragma once

#include <atomic>
#include <memory>
#include <mutex>
#include <shared_mutex>

#include "densemap/dense/kernel_layer.h"
#include "densemap/server/map_store.h"
#include "densemap/server/pipeline_stage.h"
#include "densemap/server/update_priority.h"

namespace densemap::server {

/// The dense layer shared by its stage (one writer) and the query handlers (readers).
class DenseStore {
 public:
  explicit DenseStore(std::unique_ptr<dense::KernelLayer> layer) : layer_(std::move(layer)) {}

  template <class F>
  auto read(F&& f) const {
    std::shared_lock lock(mutex_);
    return f(static_cast<const dense::KernelLayer&>(*layer_), version_.load(std::memory_order_acquire));
  }
  /// Scans integrated so far.
  std::uint64_t version() const { return version_.load(std::memory_order_acquire); }
  dense::KernelLayer& writerView() { return *layer_; }
  void commit(dense::KernelLayer::Prepared& prepared) {
    std::unique_lock lock(mutex_);
    layer_->commit(prepared);
    version_.fetch_add(1, std::memory_order_release);
  }
  void clear() {
    std::unique_lock lock(mutex_);
    layer_->clear();
  }

 private:
  std::unique_ptr<dense::KernelLayer> layer_;
  mutable WriterPreferringMutex mutex_;
  std::atomic<std::uint64_t> version_{0};
};

class DenseStage : public PipelineStage {
 public:
  /// `nice` > 0: the stage's thread and its OpenMP team run at that nice value (set on the first scan).
  explicit DenseStage(DenseStore& store, int nice = 0) : store_(store), nice_(nice) {}
  std::string name() const override { return "dense"; }
  OverflowPolicy inputPolicy() const override { return OverflowPolicy::kDropOldest; }
  StageResult process(ScanJob& job) override {
    if (!niced_ && nice_ > 0) setThreadsNice(openmpTeamThreadIds(), nice_);
    niced_ = true;
    // The occupancy stage before this one left the points in the world frame.
    std::vector<geometry::Vec3f> converted;
    if (job.scan.frame != io::PointFrame::kWorld) converted = job.scan.worldPoints();
    const auto& points = job.scan.frame == io::PointFrame::kWorld ? job.scan.points : converted;
    auto prepared = store_.writerView().prepare(points, job.scan.origin());
    store_.commit(prepared);
    return {};
  }

 private:
  DenseStore& store_;
  int nice_ = 0;
  bool niced_ = false;
};

}  // namespace densemap::server
