#include "densemap/io/procedural_scene.h"

#include <algorithm>
#include <cmath>
#include <random>

namespace densemap::io {

namespace {
constexpr double kEps = 1e-9;

std::optional<double> hitBox(const ProceduralScene::Box& b, const Eigen::Vector3d& o,
                             const Eigen::Vector3d& d) {
  double t0 = 0.0, t1 = std::numeric_limits<double>::infinity();
  for (int a = 0; a < 3; ++a) {
    if (std::fabs(d[a]) < kEps) {
      if (o[a] < b.lo[a] || o[a] > b.hi[a]) return std::nullopt;
      continue;
    }
    double ta = (b.lo[a] - o[a]) / d[a], tb = (b.hi[a] - o[a]) / d[a];
    if (ta > tb) std::swap(ta, tb);
    t0 = std::max(t0, ta);
    t1 = std::min(t1, tb);
    if (t0 > t1) return std::nullopt;
  }
  return t0 > kEps ? std::optional<double>(t0) : std::nullopt;
}

std::optional<double> hitCylinder(const ProceduralScene::Cylinder& c, const Eigen::Vector3d& o,
                                  const Eigen::Vector3d& d) {
  std::optional<double> best;
  auto consider = [&](double t) {
    if (t > kEps && (!best || t < *best)) best = t;
  };
  const double ox = o.x() - c.center.x(), oy = o.y() - c.center.y();
  const double a = d.x() * d.x() + d.y() * d.y();
  if (a > kEps) {
    const double b = 2.0 * (ox * d.x() + oy * d.y());
    const double cc = ox * ox + oy * oy - c.radius * c.radius;
    const double disc = b * b - 4.0 * a * cc;
    if (disc >= 0.0) {
      const double sq = std::sqrt(disc);
      for (double t : {(-b - sq) / (2.0 * a), (-b + sq) / (2.0 * a)}) {
        const double z = o.z() + t * d.z();
        if (z >= c.z0 && z <= c.z1) consider(t);
      }
    }
  }
  if (std::fabs(d.z()) > kEps) {  // end caps
    for (double zc : {c.z0, c.z1}) {
      const double t = (zc - o.z()) / d.z();
      const double x = ox + t * d.x(), y = oy + t * d.y();
      if (x * x + y * y <= c.radius * c.radius) consider(t);
    }
  }
  return best;
}

std::optional<double> hitSphere(const ProceduralScene::Sphere& s, const Eigen::Vector3d& o,
                                const Eigen::Vector3d& d) {
  const Eigen::Vector3d oc = o - s.center;
  const double b = oc.dot(d);
  const double c = oc.squaredNorm() - s.radius * s.radius;
  const double disc = b * b - c;
  if (disc < 0.0) return std::nullopt;
  const double sq = std::sqrt(disc);
  if (-b - sq > kEps) return -b - sq;
  if (-b + sq > kEps) return -b + sq;
  return std::nullopt;
}
}  // namespace

ProceduralScene::ProceduralScene(const SceneOptions& opt) : options_(opt) {
  std::mt19937_64 rng(opt.seed);
  auto uni = [&](double a, double b) { return std::uniform_real_distribution<double>(a, b)(rng); };
  const double half = opt.length / 2.0;
  // Buildings: one per slot along each side of the road.
  for (int side : {-1, 1}) {
    const double slot = opt.length / opt.buildings_per_side;
    for (int i = 0; i < opt.buildings_per_side; ++i) {
      const double x0 = -half + i * slot + uni(0.5, 3.0), x1 = -half + (i + 1) * slot - uni(0.5, 3.0);
      const double y_near = opt.road_half_width + uni(0.0, 3.0), y_far = y_near + uni(6.0, 14.0);
      const double h = uni(6.0, 20.0);
      const double y0 = side > 0 ? y_near : -y_far, y1 = side > 0 ? y_far : -y_near;
      boxes_.push_back({{x0, y0, 0.0}, {x1, y1, h}});
    }
  }
  // Parked boxes (car-sized) in a lane 3-5 m from the centre line.
  for (int i = 0; i < opt.boxes; ++i) {
    const double side = uni(0.0, 1.0) < 0.5 ? -1.0 : 1.0;
    const double x = uni(-half, half), y = side * uni(3.2, 4.6);
    const double lx = uni(3.6, 4.8), ly = uni(1.6, 2.0), h = uni(1.3, 1.9);
    boxes_.push_back({{x - lx / 2, y - ly / 2, 0.0}, {x + lx / 2, y + ly / 2, h}});
  }
  // Poles near the kerb.
  for (int i = 0; i < opt.poles; ++i) {
    const double side = uni(0.0, 1.0) < 0.5 ? -1.0 : 1.0;
    cylinders_.push_back({{uni(-half, half), side * uni(5.4, 6.4)}, uni(0.08, 0.2), 0.0, uni(3.5, 8.0)});
  }
  // Trees: trunk plus crown.
  for (int i = 0; i < opt.trees; ++i) {
    const double side = uni(0.0, 1.0) < 0.5 ? -1.0 : 1.0;
    const Eigen::Vector2d c(uni(-half, half), side * uni(5.0, 6.5));
    const double trunk = uni(2.0, 3.5), crown = uni(1.2, 2.5);
    cylinders_.push_back({c, uni(0.15, 0.35), 0.0, trunk});
    spheres_.push_back({{c.x(), c.y(), trunk + 0.6 * crown}, crown});
  }
  if (opt.pavements) {
    // Raised 0.1-0.2 m from the kerb to the buildings (the parked lane ends at 5.5 m).
    for (int side : {-1, 1}) {
      const double kerb = 5.5, outer = opt.road_half_width + 20.0, h = uni(0.1, 0.2);
      boxes_.push_back(
          {{-half - 10.0, side > 0 ? kerb : -outer, 0.0}, {half + 10.0, side > 0 ? outer : -kerb, h}});
    }
  }
  for (int i = 0; i < opt.hedges; ++i) {
    const double side = uni(0.0, 1.0) < 0.5 ? -1.0 : 1.0;
    const double x = uni(-half, half), length = uni(3.0, 12.0), y = side * uni(6.5, 7.5),
                 depth = uni(0.6, 1.2);
    hedges_.push_back({{x - length / 2, y - depth / 2, 0.0}, {x + length / 2, y + depth / 2, uni(0.7, 1.6)}});
  }
}

std::optional<double> ProceduralScene::cast(const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                                            double max_range) const {
  std::optional<double> best;
  auto consider = [&](std::optional<double> t) {
    if (t && *t <= max_range && (!best || *t < *best)) best = t;
  };
  if (d.z() < -kEps) consider(-o.z() / d.z());  // ground plane z = 0
  for (const Box& b : boxes_) consider(hitBox(b, o, d));
  for (const Cylinder& c : cylinders_) consider(hitCylinder(c, o, d));
  for (const Sphere& s : spheres_) consider(hitSphere(s, o, d));
  for (const Box& b : hedges_) consider(hitBox(b, o, d));
  return best;
}

std::optional<ProceduralScene::Hit> ProceduralScene::castHit(const Eigen::Vector3d& o,
                                                             const Eigen::Vector3d& d,
                                                             double max_range) const {
  // Which primitive was nearest: kind 0 ground, 1 box, 2 cylinder, 3 sphere (crown), 4 hedge.
  std::optional<double> best;
  int kind = -1;
  std::size_t which = 0;
  auto consider = [&](std::optional<double> t, int k, std::size_t i) {
    if (t && *t <= max_range && (!best || *t < *best)) {
      best = t;
      kind = k;
      which = i;
    }
  };
  if (d.z() < -kEps) consider(-o.z() / d.z(), 0, 0);
  for (std::size_t i = 0; i < boxes_.size(); ++i) consider(hitBox(boxes_[i], o, d), 1, i);
  for (std::size_t i = 0; i < cylinders_.size(); ++i) consider(hitCylinder(cylinders_[i], o, d), 2, i);
  for (std::size_t i = 0; i < spheres_.size(); ++i) consider(hitSphere(spheres_[i], o, d), 3, i);
  for (std::size_t i = 0; i < hedges_.size(); ++i) consider(hitBox(hedges_[i], o, d), 4, i);
  if (!best) return std::nullopt;
  Hit hit;
  hit.range = *best;
  const Eigen::Vector3d p = o + *best * d;
  hit.vegetation = kind == 3 || kind == 4;
  if (kind == 1 || kind == 4) {
    // The face the point lies on: the axis where it is nearest a bound.
    const Box& b = kind == 1 ? boxes_[which] : hedges_[which];
    double nearest = std::numeric_limits<double>::infinity();
    for (int a = 0; a < 3; ++a)
      for (double bound : {b.lo[a], b.hi[a]})
        if (std::abs(p[a] - bound) < nearest) {
          nearest = std::abs(p[a] - bound);
          hit.normal = Eigen::Vector3d::Unit(a);
        }
  } else if (kind == 2) {
    const Cylinder& c = cylinders_[which];
    const Eigen::Vector2d radial = p.head<2>() - c.center;
    const bool cap = std::abs(p.z() - c.z0) < 1e-6 || std::abs(p.z() - c.z1) < 1e-6;
    hit.normal = cap || radial.norm() < kEps ? Eigen::Vector3d::UnitZ()
                                             : Eigen::Vector3d(radial.x(), radial.y(), 0.0).normalized();
  } else if (kind == 3) {
    hit.normal = (p - spheres_[which].center).normalized();
  }
  if (hit.normal.dot(d) > 0) hit.normal = -hit.normal;
  return hit;
}

}  // namespace densemap::io
