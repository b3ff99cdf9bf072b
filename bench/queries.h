// Benchmark inputs, built once outside the timed loops: per shape, a `random` family (rays from
// a shell toward the shape's neighbourhood, mostly hits) and a `grazing` family (rays aimed at
// silhouettes, edges and corners, where filters fail and exact paths run).
#pragma once

#include <random>
#include <vector>

#include "rayproof/shapes.h"

namespace rayproof::bench {

struct Query {
  Ray ray;
  Shape shape;
};

enum class Family { random, grazing };

inline std::vector<Query> make_queries(ShapeKind kind, Family family, size_t n, std::uint64_t seed = 1234) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> g;
  std::uniform_real_distribution<double> u(-1, 1), unit(0, 1);
  auto gauss_dir = [&] { return normalized(Vec3(g(rng), g(rng), g(rng))); };
  std::vector<Query> qs;
  qs.reserve(n);
  while (qs.size() < n) {
    Shape shape;
    Vec3 target;
    switch (kind) {
      case ShapeKind::sphere: {
        const Sphere s{Vec3(u(rng), u(rng), u(rng)), 0.5 + 0.4 * unit(rng)};
        shape = s;
        const Vec3 axis = gauss_dir();
        const Vec3 side = normalized(cross(axis, gauss_dir()));
        // grazing: a point at distance r(1 + tiny) from the centre, perpendicular to the ray
        target = family == Family::random ? Vec3(u(rng), u(rng), u(rng))
                                          : Vec3(s.center + s.radius * (1 + std::ldexp(g(rng), -40)) * side);
        const Vec3 o = target - 5 * axis;
        qs.push_back({Ray{o, target - o}, shape});
        continue;
      }
      case ShapeKind::plane: {
        const Plane p{Vec3(u(rng), u(rng), 1), u(rng)};
        shape = p;
        const Vec3 o = 5 * gauss_dir();
        Vec3 d = Vec3(u(rng), u(rng), u(rng)) - o;
        if (family == Family::grazing) d = cross(p.normal, gauss_dir()) + std::ldexp(g(rng), -45) * p.normal;
        qs.push_back({Ray{o, d}, shape});
        continue;
      }
      case ShapeKind::triangle: {
        const Triangle t{{Vec3(-1, -1, u(rng)), Vec3(1, -1, u(rng)), Vec3(u(rng), 1, u(rng))}};
        shape = t;
        const int e = static_cast<int>(rng() % 3);
        const double w = unit(rng);
        target = family == Family::random ? Vec3(u(rng) * 0.8, u(rng) * 0.8, u(rng) * 0.5)
                                          : Vec3(t.v[e] + w * (t.v[(e + 1) % 3] - t.v[e]));  // on an edge
        break;
      }
      case ShapeKind::box: {
        const Vec3 c(u(rng) * 0.3, u(rng) * 0.3, u(rng) * 0.3);
        const Box b{c - Vec3::Constant(0.5), c + Vec3::Constant(0.5)};
        shape = b;
        target = family == Family::random ? Vec3(u(rng), u(rng), u(rng))
                                          : Vec3(b.min.x(), b.min.y(), b.min.z() + unit(rng));  // on an edge
        break;
      }
    }
    const Vec3 o = 5 * gauss_dir();
    qs.push_back({Ray{o, target - o}, shape});
  }
  return qs;
}

}  // namespace rayproof::bench
