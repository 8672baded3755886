// The BGKOctoMap baseline (Doherty et al.) in the same framework: every sample gets the same isotropic
// sparse kernel of length scale `ell` and signal variance `sf2` (la3dm's defaults: 0.2 m and 1.0).
#pragma once

#include "densemap/dense/kernel_layer.h"

namespace densemap::dense {

struct IsotropicKernelOptions {
  KernelLayerOptions layer{};
  float ell = 0.2f;  ///< length scale (kernel support radius), metres
  float sf2 = 1.0f;  ///< signal variance (kernel weight)
};

class IsotropicKernelLayer : public KernelLayer {
 public:
  explicit IsotropicKernelLayer(const IsotropicKernelOptions& options = {})
      : KernelLayer(options.layer), iso_(options) {}
  std::string name() const override { return "bgk"; }

 protected:
  void bandwidths(const SampleSet& samples, double max_range, std::vector<Kernel>& out) override;

 private:
  IsotropicKernelOptions iso_;
};

}  // namespace densemap::dense
