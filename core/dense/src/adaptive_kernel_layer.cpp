#include "densemap/dense/adaptive_kernel_layer.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Eigenvalues>
#include <nanoflann.hpp>

namespace densemap::dense {

namespace {

/// nanoflann's view of the sample points.
struct PointCloudAdaptor {
  const std::vector<Vec3f>& pts;
  std::size_t kdtree_get_point_count() const { return pts.size(); }
  float kdtree_get_pt(std::size_t i, std::size_t dim) const { return pts[i][static_cast<int>(dim)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};
using KdTree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, PointCloudAdaptor>,
                                                   PointCloudAdaptor, 3, std::uint32_t>;

}  // namespace

double AdaptiveKernelLayer::searchRadius(float range, double max_range) const {
  const double res = options_.resolution, far = options_.sampling.free_sample_distance;
  const double t = max_range > 0 ? std::clamp(static_cast<double>(range) / max_range, 0.0, 1.0) : 1.0;
  return std::max(adaptive_.min_search_radius, res + (far - res) * t);
}

void AdaptiveKernelLayer::bandwidths(const SampleSet& samples, double max_range, std::vector<Kernel>& out) {
  const std::size_t n = samples.size();
  out.resize(n);
  if (n == 0) return;
  PointCloudAdaptor cloud{samples.points};
  KdTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
  tree.buildIndex();
  const float res = static_cast<float>(options_.resolution);
  // Floor on the covariance so a flat neighbourhood (a wall) still gives a kernel a quarter cell thick.
  const float floor_var = 0.0625f * res * res;
  const int steps = std::max(2, adaptive_.scale_steps);
#pragma omp parallel
  {
    std::vector<std::pair<std::uint32_t, float>> found;
    std::vector<float> r_same, t_same, r_other;
#pragma omp for schedule(dynamic, 128)
    for (std::size_t i = 0; i < n; ++i) {
      const Vec3f xi = samples.points[i];
      const bool yi = samples.occupied[i] != 0;
      float radius = static_cast<float>(searchRadius(samples.range[i], max_range));
      if (yi) radius = std::max(radius, static_cast<float>(adaptive_.min_occupied_search_radius));
      found.clear();
      nanoflann::SearchParams params;
      params.sorted = false;
      tree.radiusSearch(xi.data(), radius * radius, found, params);
      // Sec. 3.3.3, step 1: covariance of the same-label neighbours.
      Eigen::Vector3f mean = Eigen::Vector3f::Zero();
      int same = 0;
      for (const auto& [j, d2] : found) {
        if ((samples.occupied[j] != 0) == yi) {
          mean += samples.points[j];
          ++same;
        }
      }
      Eigen::Matrix3f sigma;
      if (same >= adaptive_.min_neighbours && !(adaptive_.isotropic_free_kernels && !yi)) {
        mean /= static_cast<float>(same);
        sigma.setZero();
        for (const auto& [j, d2] : found) {
          if ((samples.occupied[j] != 0) != yi) continue;
          const Eigen::Vector3f d = samples.points[j] - mean;
          sigma += d * d.transpose();
        }
        sigma /= static_cast<float>(same);
        sigma.diagonal().array() += floor_var;
      } else {
        sigma = Eigen::Matrix3f::Identity() * (0.25f * radius * radius);  // documented fallback
      }
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3f> eig;
      eig.computeDirect(sigma);
      float lambda_max = std::max(eig.eigenvalues().maxCoeff(), floor_var);
      if (adaptive_.support_to_radius) {
        // The covariance's shape, sized so the kernel's support reaches the search radius along the
        // principal axis (a compact kernel on the raw covariance would end at one standard deviation).
        sigma *= radius * radius / lambda_max;
        lambda_max = radius * radius;
      }
      const Eigen::Vector3f lambdas = eig.eigenvalues().cwiseMax(floor_var) *
                                      (lambda_max / std::max(eig.eigenvalues().maxCoeff(), floor_var));
      const Eigen::Matrix3f sigma_inv = sigma.inverse();
      // Mahalanobis distances (under Sigma) of the neighbours, split by label.
      r_same.clear();
      t_same.clear();
      r_other.clear();
      for (const auto& [j, d2] : found) {
        if (j == i) continue;
        const Eigen::Vector3f d = samples.points[j] - xi;
        const float r = std::sqrt(d.dot(sigma_inv * d));
        if ((samples.occupied[j] != 0) == yi) {
          r_same.push_back(r);
          t_same.push_back(sparseKernel(r));  // Eq. 3.6's target, the same at every scale
        } else {
          r_other.push_back(r);
        }
      }
      // Step 2: the scale s minimising Eq. 3.7, s^-3/2 * sum_j (t_j - k(r_j / sqrt(s)))^2, with the targets
      // of Eq. 3.6 (k(r_j) for same-label neighbours, 0 for the others), over the scales whose support
      // stays between half a cell and the search radius.
      const float s_min = 0.25f * res * res / lambda_max;
      const float s_max = std::max(s_min, radius * radius / lambda_max);
      // The covariance itself (s = 1) is the incumbent: a candidate must do strictly better (with no
      // neighbours to disagree, every scale scores 0 and the covariance stays).
      float best_s = std::clamp(1.0f, s_min, s_max), best_e = INFINITY;
      for (int k = -1; k < steps; ++k) {
        const float s =
            k < 0 ? best_s
                  : s_min * std::pow(s_max / s_min, static_cast<float>(k) / static_cast<float>(steps - 1));
        const float inv_sqrt_s = 1.0f / std::sqrt(s);
        float e = 0.0f;
        for (std::size_t j = 0; j < r_same.size(); ++j) {
          const float diff = t_same[j] - sparseKernel(r_same[j] * inv_sqrt_s);
          e += diff * diff;
        }
        for (float r : r_other) {
          const float v = sparseKernel(r * inv_sqrt_s);
          e += v * v;
        }
        e *= inv_sqrt_s * inv_sqrt_s * inv_sqrt_s;
        if (e < best_e) {
          best_e = e;
          best_s = s;
        }
      }
      // H = s Sigma, with every axis of the support at least one cell long: a thinner kernel could miss
      // the centre of the very cell its sample lies in.
      const Eigen::Vector3f h = (lambdas * best_s).cwiseMax(res * res);
      const Eigen::Matrix3f& v = eig.eigenvectors();
      const Eigen::Matrix3f hm = v * h.asDiagonal() * v.transpose();
      Kernel& kern = out[i];
      kern.h_inv = v * h.cwiseInverse().asDiagonal() * v.transpose();
      kern.half_extent = hm.diagonal().cwiseSqrt();
      // |H|^-1/2 of Eq. 3.2 as it stands (metres^-3). It must not be rescaled (an earlier version multiplied
      // it by the cell volume): the Beta prior (Eq. 3.2, 3.3) is added to these sums, and weights ~10^4
      // times smaller let the prior pull cells with only free evidence towards 0.5 (held-out AUC on la3dm
      // structured at 0.05 m 0.957 -> 0.961, docs/BENCHMARKS.md).
      kern.weight = 1.0f / std::sqrt(h.prod());
    }
  }
}

}  // namespace densemap::dense
