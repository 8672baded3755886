#include "densemap/dense/isotropic_kernel_layer.h"

namespace densemap::dense {

void IsotropicKernelLayer::bandwidths(const SampleSet& samples, double, std::vector<Kernel>& out) {
  Kernel k;
  k.h_inv = Eigen::Matrix3f::Identity() / (iso_.ell * iso_.ell);
  k.half_extent = Eigen::Vector3f::Constant(iso_.ell);
  k.weight = iso_.sf2;
  out.assign(samples.size(), k);
}

}  // namespace densemap::dense
