// Implicit LiDAR Network (ILN, Ch. 4): predicts the range of any query laser direction as a weighted sum of
// its 4 neighbouring measured ranges, the weights coming from deep features and self-attention (Eq. 4.3).
// libtorch stays behind this header (one translation unit includes <torch/torch.h>).
#pragma once

#include <cstdint>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "densemap/densify/range_upsampler.h"

namespace densemap::densify {

/// Network size. The full model is Ch. 4's; the compact one is our real-time CPU variant.
struct IlnOptions {
  int blocks = 16;          ///< EDSR-baseline residual blocks in the encoder (Sec. 4.3.1)
  int channels = 64;        ///< encoder feature channels = token width
  int heads = 8;            ///< self-attention heads of channels / heads dims each (Sec. 4.3.2)
  int mlp = 64;             ///< transformer MLP width (GELU)
  float max_range = 80.0f;  ///< ranges are normalised to [-1, 1] as r / max_range * 2 - 1

  static IlnOptions full() { return {}; }
  /// 4 blocks, 16 channels, 2 heads x 8, MLP 32: the server's default (see the model card).
  static IlnOptions compact() { return {4, 16, 2, 32, 80.0f}; }
};

struct IlnTrainOptions {
  int batch = 8;                   ///< examples per step
  int crop_columns = 256;          ///< each example is a random crop of this many input columns
  int queries_per_example = 2048;  ///< target pixels sampled per crop
  double learning_rate = 1e-4;     ///< Adam (Sec. 4.4.2)
};

class IlnUpsampler : public RangeUpsampler {
 public:
  /// A freshly initialised network (seeded).
  explicit IlnUpsampler(const IlnOptions& options = IlnOptions::compact(), std::uint64_t seed = 1);
  ~IlnUpsampler() override;
  IlnUpsampler(IlnUpsampler&&) noexcept;
  IlnUpsampler& operator=(IlnUpsampler&&) noexcept;

  /// Loads weights (and, when present, the optimiser state and step of a checkpoint). Throws
  /// std::runtime_error naming the file when it is missing or not an ILN checkpoint.
  static IlnUpsampler load(const std::string& path);
  /// Saves the weights; with `with_optimizer`, also the Adam state and the step, to resume training.
  void save(const std::string& path, bool with_optimizer = false) const;

  std::string name() const override { return name_; }
  void setName(std::string name) { name_ = std::move(name); }
  const IlnOptions& options() const;
  std::size_t parameterCount() const;
  std::uint64_t step() const;

  /// Predicts every pixel of `output`. Pixels that sit exactly on a measured input pixel keep its range,
  /// so densifying never alters the beams the LiDAR measured.
  RangeImage upsample(const RangeImage& input, const LidarGeometry& output) override;

  /// One Adam step on a batch drawn from `examples` (random examples, crops and target pixels); returns the
  /// batch's L1 loss in metres.
  double trainStep(const std::vector<RangeImagePair>& examples, const IlnTrainOptions& options,
                   std::mt19937& rng);

  /// Inference through the hand-written weight head (default) or through libtorch's modules (tests compare
  /// the two; both compute the same function).
  void useFastHead(bool on) { use_fast_head_ = on; }

  /// Keeps the weights but forgets the optimiser state and the step count (fine-tuning starts here).
  void restartTraining();

  /// Threads libtorch may use (at::set_num_threads; its default here is 1).
  static void setThreads(int threads);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::string name_ = "iln";
  bool use_fast_head_ = true;
};

}  // namespace densemap::densify
