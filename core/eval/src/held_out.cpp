#include "densemap/eval/held_out.h"

#include <algorithm>
#include <numeric>

namespace densemap::eval {

HeldOutSplit splitScan(const std::vector<Vec3f>& points, const Vec3f& origin, const HeldOutOptions& o,
                       std::mt19937_64& rng) {
  std::vector<std::size_t> order(points.size());
  std::iota(order.begin(), order.end(), 0);
  std::shuffle(order.begin(), order.end(), rng);
  const auto held = static_cast<std::size_t>(o.held_out_fraction * static_cast<double>(points.size()) + 0.5);
  HeldOutSplit out;
  std::vector<std::uint8_t> is_test(points.size(), 0);
  for (std::size_t k = 0; k < held; ++k) is_test[order[k]] = 1;
  std::uniform_real_distribution<float> unit(0.0f, 1.0f);
  for (std::size_t i = 0; i < points.size(); ++i) {
    const Vec3f& p = points[i];
    if (!p.allFinite()) continue;
    if (!is_test[i]) {
      out.map_points.push_back(p);
      continue;
    }
    const Vec3f ray = p - origin;
    const float length = ray.norm();
    if (length <= static_cast<float>(o.end_margin)) continue;
    if (o.max_range > 0 && length > o.max_range) continue;
    out.tests.push_back({p, true});
    const float t = unit(rng) * (length - static_cast<float>(o.end_margin));
    out.tests.push_back({origin + ray * (t / length), false});
  }
  return out;
}

}  // namespace densemap::eval
