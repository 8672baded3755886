#include "densemap/dense/dense_layer_factory.h"

#include <stdexcept>

#include "densemap/dense/adaptive_kernel_layer.h"
#include "densemap/dense/isotropic_kernel_layer.h"

namespace densemap::dense {

std::unique_ptr<KernelLayer> makeDenseLayer(const DenseLayerOptions& o, double default_resolution) {
  if (o.method == "none") return nullptr;
  KernelLayerOptions lo;
  lo.resolution = o.resolution > 0 ? o.resolution : default_resolution;
  if (!(lo.resolution > 0)) throw std::invalid_argument("the dense layer's resolution must be positive");
  lo.sampling.free_sample_distance = o.free_sample_distance;
  lo.sampling.max_range = o.max_range;
  lo.sampling.free_voxel_size = o.free_voxel_size;
  lo.seed = o.seed;
  if (o.method == "akimap") {
    AdaptiveKernelOptions a;
    a.layer = lo;
    a.min_search_radius = o.min_search_radius;
    a.isotropic_free_kernels = o.isotropic_free_kernels;
    a.min_occupied_search_radius = o.min_occupied_search_radius;
    return std::make_unique<AdaptiveKernelLayer>(a);
  }
  if (o.method == "bgk") {
    IsotropicKernelOptions b;
    b.layer = lo;
    return std::make_unique<IsotropicKernelLayer>(b);
  }
  throw std::invalid_argument("unknown dense layer '" + o.method + "' (use none, akimap or bgk)");
}

}  // namespace densemap::dense
