// densemap-kdtree-bench: the measurement behind AKIMap's k-d tree choice. Builds nanoflann's and PCL's
// (FLANN) k-d trees on one scan's occupancy samples and runs AKIMap's radius searches with each, in the
// same process, checking both find the same neighbours.
#include <chrono>
#include <cstdio>

#include <pcl/kdtree/kdtree_flann.h>
#include <pcl/point_types.h>
#include <spdlog/spdlog.h>
#include <CLI/CLI.hpp>
#include <nanoflann.hpp>

#include "densemap/cli/cli_common.h"
#include "densemap/dense/adaptive_kernel_layer.h"
#include "densemap/dense/occupancy_samples.h"
#include "densemap/sources/open_source.h"

using namespace densemap;
using Clock = std::chrono::steady_clock;

namespace {
struct Cloud {
  const std::vector<geometry::Vec3f>& pts;
  std::size_t kdtree_get_point_count() const { return pts.size(); }
  float kdtree_get_pt(std::size_t i, std::size_t d) const { return pts[i][static_cast<int>(d)]; }
  template <class B>
  bool kdtree_get_bbox(B&) const {
    return false;
  }
};
double ms(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"densemap-kdtree-bench: nanoflann vs PCL k-d tree on AKIMap's neighbour searches"};
  std::string source = "sim";
  std::size_t scan = 0;
  double resolution = 0.2, max_range = 30, free_voxel = 0.3;
  int repeat = 3;
  app.add_option("--source", source, "scan source")->capture_default_str();
  app.add_option("--scan", scan, "scan index")->capture_default_str();
  app.add_option("--resolution", resolution, "cell size")->capture_default_str();
  app.add_option("--max-range", max_range, "ray cut (m)")->capture_default_str();
  app.add_option("--free-voxel", free_voxel, "one free sample per voxel of this size")->capture_default_str();
  app.add_option("--repeat", repeat, "runs; the median is printed")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  cli::setupLogging("warn");
  try {
    const auto src = sources::openSource(source);
    const io::Scan s = src->read(scan);
    dense::SamplingOptions so;
    so.resolution = resolution;
    so.max_range = max_range;
    so.free_voxel_size = free_voxel;
    std::mt19937_64 rng(1);
    const dense::SampleSet samples = dense::sampleScan(s.worldPoints(), s.origin(), so, rng);
    dense::AdaptiveKernelOptions ao;
    ao.layer.resolution = resolution;
    ao.layer.sampling = so;
    const dense::AdaptiveKernelLayer layer(ao);
    std::vector<float> radii(samples.size());
    for (std::size_t i = 0; i < samples.size(); ++i)
      radii[i] = static_cast<float>(layer.searchRadius(samples.range[i], max_range));

    std::vector<double> nf_build, nf_query, pcl_build, pcl_query;
    std::size_t nf_found = 0, pcl_found = 0;
    for (int r = 0; r < repeat; ++r) {
      auto t = Clock::now();
      Cloud cloud{samples.points};
      nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<float, Cloud>, Cloud, 3, std::uint32_t>
          nf(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(16));
      nf.buildIndex();
      nf_build.push_back(ms(t));
      t = Clock::now();
      std::vector<std::pair<std::uint32_t, float>> found;
      nanoflann::SearchParams params;
      params.sorted = false;
      nf_found = 0;
      for (std::size_t i = 0; i < samples.size(); ++i) {
        nf_found += nf.radiusSearch(samples.points[i].data(), radii[i] * radii[i], found, params);
      }
      nf_query.push_back(ms(t));

      t = Clock::now();
      auto pc = pcl::make_shared<pcl::PointCloud<pcl::PointXYZ>>();
      pc->reserve(samples.size());
      for (const auto& p : samples.points) pc->push_back(pcl::PointXYZ(p.x(), p.y(), p.z()));
      pcl::KdTreeFLANN<pcl::PointXYZ> kd(false);
      kd.setInputCloud(pc);
      pcl_build.push_back(ms(t));
      t = Clock::now();
      std::vector<int> idx;
      std::vector<float> d2;
      pcl_found = 0;
      for (std::size_t i = 0; i < samples.size(); ++i) {
        pcl_found += static_cast<std::size_t>(kd.radiusSearch((*pc)[i], radii[i], idx, d2));
      }
      pcl_query.push_back(ms(t));
    }
    auto median = [](std::vector<double> v) {
      std::sort(v.begin(), v.end());
      return v[v.size() / 2];
    };
    std::printf("%s scan %zu: %zu samples (%zu occupied), one thread, median of %d\n",
                src->describe().c_str(), scan, samples.size(), samples.occupiedCount(), repeat);
    std::printf("  nanoflann  build %7.1f ms  radius searches %8.1f ms  (%zu neighbours)\n", median(nf_build),
                median(nf_query), nf_found);
    std::printf("  PCL FLANN  build %7.1f ms  radius searches %8.1f ms  (%zu neighbours)\n",
                median(pcl_build), median(pcl_query), pcl_found);
    std::printf("  PCL / nanoflann: searches %.2fx\n", median(pcl_query) / median(nf_query));
    if (nf_found != pcl_found) std::printf("  note: the neighbour counts differ (boundary ties)\n");
  } catch (const std::exception& e) {
    spdlog::error("{}", e.what());
    return 1;
  }
  return 0;
}
