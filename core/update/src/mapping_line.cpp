#include "densemap/update/mapping_line.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

namespace densemap::update {

GridPlanes::GridPlanes(const geometry::KeyConverter& conv, int origin_key_coord)
    : resolution(conv.resolution()),
      origin_center(conv.toCoord(static_cast<geometry::KeyCoord>(origin_key_coord))),
      half_up(static_cast<float>(1 * conv.resolution() * 0.5)),
      half_down(static_cast<float>(-1 * conv.resolution() * 0.5)),
      origin_key(origin_key_coord) {}

void MappingLine::build(double ou, double ov, int origin_u, int origin_v, int cell_u, int cell_v,
                        const GridPlanes& pu, const GridPlanes& pv) {
  slopes_.clear();
  const int du = cell_u - origin_u, dv = cell_v - origin_v;
  trivial_ = du == 0 && dv == 0;
  if (trivial_) return;
  // Processing direction: the axis along which the cell is further from the origin (Sec. 2.3.1), so every
  // ray toward the cell advances along it and slopes stay bounded.
  swapped_ = std::abs(dv) > std::abs(du);
  const GridPlanes& pp = swapped_ ? pv : pu;  // processing axis planes
  const GridPlanes& pq = swapped_ ? pu : pv;
  const double op = swapped_ ? ov : ou, oq = swapped_ ? ou : ov;
  const int kp_o = swapped_ ? origin_v : origin_u, kq_o = swapped_ ? origin_u : origin_v;
  const int kp_c = swapped_ ? cell_v : cell_u, kq_c = swapped_ ? cell_u : cell_v;
  ou_ = ou;
  ov_ = ov;
  const int sp = kp_c > kp_o ? 1 : -1;

  // Slope range of the seed frustum: the cell box (padded, so the frustum is never too narrow).
  const double pad = 1e-6 * pp.resolution;
  const double cp0 = pp.plane(kp_c) - pad, cp1 = pp.plane(kp_c + 1) + pad;
  const double cq0 = pq.plane(kq_c) - pad, cq1 = pq.plane(kq_c + 1) + pad;
  double m_min = INFINITY, m_max = -INFINITY;
  for (double cp : {cp0, cp1})
    for (double cq : {cq0, cq1}) {
      const double m = (cq - oq) / (cp - op);
      m_min = std::min(m_min, m);
      m_max = std::max(m_max, m);
    }
  // Alg. 1: for each slice between the origin's and the cell's, project the grid points of its far
  // boundary ("out" line) that lie between the frustum's intersections int_min and int_max.
  for (int n = sp > 0 ? kp_o + 1 : kp_o; sp > 0 ? n <= kp_c : n > kp_c; n += sp) {
    const double plane_p = pp.plane(n);
    const double dist = plane_p - op;
    const double a = oq + m_min * dist, b = oq + m_max * dist;
    const double int_min = std::min(a, b), int_max = std::max(a, b);
    // Candidate q planes: keys around the interval (plane(m) is within a few ulps of the key boundary).
    const double res = pq.resolution;
    const int m_lo = static_cast<int>(std::floor((int_min - pq.plane(kq_o)) / res)) + kq_o - 1;
    const int m_hi = static_cast<int>(std::floor((int_max - pq.plane(kq_o)) / res)) + kq_o + 2;
    for (int m = m_lo; m <= m_hi; ++m) {
      const double q = pq.plane(m);
      if (q < int_min || q > int_max) continue;
      slopes_.push_back((q - oq) / dist);
    }
  }
  std::sort(slopes_.begin(), slopes_.end());
  slopes_.erase(std::unique(slopes_.begin(), slopes_.end()), slopes_.end());
}

int MappingLine::classify(double u, double v) const {
  if (trivial_) return 0;
  const double p = swapped_ ? v - ov_ : u - ou_;
  const double q = swapped_ ? u - ou_ : v - ov_;
  const double m = q / p;
  if (std::isnan(m)) return -1;  // cannot be placed: its own walk
  // upper_bound without data-dependent branches: the comparisons become conditional moves, where a
  // branching search mispredicts about half its steps (rays in a cell are in point order, not slope order),
  // and classify ran three times per point was the generator's largest cost on coarse grids.
  const double* s = slopes_.data();
  std::size_t len = slopes_.size(), at = 0;
  if (len > 0) {
    const double* base = s;
    while (len > 1) {
      const std::size_t half = len / 2;
      base = base[half] <= m ? base + half : base;
      len -= half;
    }
    at = static_cast<std::size_t>(base - s) + (*base <= m ? 1 : 0);
  }
  auto near = [&](double g) {
    return std::fabs(m - g) <= kSlopeTolerance * (std::fabs(m) + std::fabs(g)) + 1e-300;
  };
  if (at < slopes_.size() && near(s[at])) return -1;
  if (at > 0 && near(s[at - 1])) return -1;
  return static_cast<int>(at);
}

}  // namespace densemap::update
