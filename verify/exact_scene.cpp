#include "rayproof/verify/exact_scene.h"

#include <cmath>

namespace rayproof {

namespace {

// The exact t of the pruning bound: a contact whose rounded t is `best` has its exact t below
// the next double up (rounding to nearest moves it by at most half an ulp), so boxes entered
// beyond next_up(best) cannot hold a nearer exact contact.
double prune_limit(double best) { return next_up(best); }

bool is_contact(const Verdict& v) { return v.cls != HitClass::miss && v.t.has_value(); }

}  // namespace

ExactTracer::ExactTracer(const SceneIndex& index) : index_(&index) {}

ExactParameter ExactTracer::exact_parameter(const Ray& ray, std::int32_t primitive) {
  const Verdict v = with_parameter_.judge(ray, index_->primitive(primitive).shape);
  return *v.exact_t;
}

bool ExactTracer::before(const Ray& ray, const ExactContact& a, const ExactContact& b) {
  if (!a.found()) return false;
  if (!b.found()) return true;
  // Rounding to nearest is monotone: different rounded values order the exact ones.
  if (a.t != b.t) return a.t < b.t;
  if (a.primitive != b.primitive) {
    const int c = compare(exact_parameter(ray, a.primitive), exact_parameter(ray, b.primitive));
    if (c != 0) return c < 0;
  }
  return index_->listed_before(a.primitive, b.primitive);
}

ExactContact ExactTracer::nearest(ShapeKind kind, const Ray& ray) {
  ExactContact best;
  double t_limit = std::numeric_limits<double>::infinity();
  index_->traverse(kind, ray, t_limit, [&](std::int32_t id, const Shape& shape) {
    const Verdict v = filtered_.judge(ray, shape);
    if (!is_contact(v)) return false;
    const ExactContact c{id, *v.t};
    if (before(ray, c, best)) {
      best = c;
      t_limit = prune_limit(best.t);
    }
    return false;
  });
  return best;
}

ExactContact ExactTracer::nearest(const Ray& ray) {
  ExactContact best;
  for (ShapeKind kind : index_->shapes_used()) {
    const ExactContact c = nearest(kind, ray);
    if (before(ray, c, best)) best = c;
  }
  return best;
}

bool ExactTracer::blocks(ShapeKind kind, const Ray& segment, std::int32_t self) {
  bool blocked = false;
  double t_limit = 1;
  index_->traverse(kind, segment, t_limit, [&](std::int32_t id, const Shape& shape) {
    if (id == self) return false;
    const Verdict v = filtered_.judge(segment, shape);
    if (!is_contact(v)) return false;
    // Rounding is monotone and 1 is a double: rounded t < 1 means exact t < 1, > 1 means > 1.
    if (*v.t < 1)
      blocked = true;
    else if (*v.t == 1)
      blocked = compare(exact_parameter(segment, id), mpq_class(1)) < 0;
    return blocked;
  });
  return blocked;
}

bool ExactTracer::blocked(const Ray& segment, std::int32_t self) {
  for (ShapeKind kind : index_->shapes_used())
    if (blocks(kind, segment, self)) return true;
  return false;
}

Vec3 ExactTracer::hit_point(const Ray& ray, const ExactContact& contact) {
  const ExactParameter t = exact_parameter(ray, contact.primitive);
  RoundingStats stats;
  Vec3 p;
  for (int k = 0; k < 3; ++k) {
    // o + d·(P + s√D)/q = (o·q + d·P + s·sgn(d)·√(d²·D)) / q: an exact parameter of its own,
    // rounded by the oracle's proved rounding (for its magnitude, with the sign put back).
    const double o = ray.origin[k], d = ray.direction[k];
    ExactParameter x;
    x.q = t.q;
    x.p = mpq_class(o) * t.q + mpq_class(d) * t.p;
    x.radicand = mpq_class(d) * mpq_class(d) * t.radicand;
    x.s = d == 0 ? 0 : (d > 0 ? t.s : -t.s);
    const int sign = compare(x, mpq_class(0));
    if (sign == 0) {
      p[k] = 0;
      continue;
    }
    if (sign < 0) {
      x.p = -x.p;
      x.s = -x.s;
    }
    const double magnitude = round_to_nearest(x, stats);
    p[k] = sign < 0 ? -magnitude : magnitude;
  }
  return p;
}

std::uint64_t ExactTracer::beyond_intervals() const {
  std::uint64_t n = 0;
  for (const Oracle* o : {&filtered_, &with_parameter_})
    for (ShapeKind k : kAllShapeKinds) {
      const OracleStats& s = o->stats(k);
      n += s.class_expansion + s.class_exact + s.rounding.expansion + s.rounding.rational;
    }
  return n;
}

}  // namespace rayproof
