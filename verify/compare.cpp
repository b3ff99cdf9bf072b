#include "rayproof/compare.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <iomanip>

namespace rayproof {

std::optional<std::uint64_t> ulp_distance(double a, double b) {
  if (std::isnan(a) || std::isnan(b)) return std::nullopt;
  // Map the IEEE bit patterns onto a line where consecutive doubles are consecutive integers.
  auto ordered = [](double x) {
    std::int64_t bits;
    std::memcpy(&bits, &x, sizeof bits);
    return bits < 0 ? -(bits & INT64_MAX) : bits;
  };
  const std::int64_t ia = ordered(a), ib = ordered(b);
  return ia > ib ? std::uint64_t(ia) - std::uint64_t(ib) : std::uint64_t(ib) - std::uint64_t(ia);
}

VariantOutcome compare_variant(const Variant& v, const Verdict& exact, const Ray& ray, const Shape& shape,
                               HitRule rule) {
  VariantOutcome out;
  out.variant = &v;
  out.hit = v.intersect(ray, shape, rule);
  if (out.hit.cls == exact.cls) {
    out.agreement = Agreement::agrees;
  } else if ((exact.cls == HitClass::tangent || exact.cls == HitClass::boundary) &&
             (out.hit.cls == HitClass::enter || out.hit.cls == HitClass::exit || out.hit.cls == HitClass::miss)) {
    out.agreement = Agreement::cannot_tell;
  } else {
    out.agreement = Agreement::wrong;
  }
  if (exact.t && out.hit.has_t()) out.ulp = ulp_distance(out.hit.t, *exact.t);
  return out;
}

ordered_json check_line(const std::string& id, const Verdict& exact, const std::vector<VariantOutcome>& outcomes) {
  ordered_json line;
  line["id"] = id;
  line["exact"] = {{"class", std::string(to_string(exact.cls))},
                   {"t", exact.t ? ordered_json(hex_double(*exact.t)) : ordered_json(nullptr)}};
  ordered_json variants = ordered_json::object();
  for (const VariantOutcome& o : outcomes)
    variants[std::string(o.variant->name)] = {
        {"class", std::string(to_string(o.hit.cls))},
        {"t", o.hit.has_t() ? ordered_json(hex_double(o.hit.t)) : ordered_json(nullptr)},
        {"ulp", o.ulp ? ordered_json(*o.ulp) : ordered_json(nullptr)},
        {"agrees", o.agreement == Agreement::agrees}};
  line["variants"] = std::move(variants);
  return line;
}

std::string expectation_mismatch(const Expectation& expect, const Verdict& exact) {
  if (expect.cls != exact.cls)
    return "expect.class is " + std::string(to_string(expect.cls)) + ", the exact class is " +
           std::string(to_string(exact.cls));
  if (expect.t) {
    if (!exact.t) return "expect.t is given but the exact contact has no t";
    if (*ulp_distance(*expect.t, *exact.t) != 0)
      return "expect.t is " + hex_double(*expect.t) + ", the correctly rounded exact t is " + hex_double(*exact.t);
  }
  return "";
}

std::uint64_t quantile(std::vector<std::uint64_t> values, double q) {
  if (values.empty()) return 0;
  const size_t rank = static_cast<size_t>(std::ceil(q * values.size()));
  const size_t k = std::min(values.size() - 1, rank == 0 ? 0 : rank - 1);
  std::nth_element(values.begin(), values.begin() + k, values.end());
  return values[k];
}

void CheckSummary::add(const Verdict& exact, const std::vector<VariantOutcome>& outcomes) {
  for (const VariantOutcome& o : outcomes) {
    PerVariant& pv = variants_[std::string(o.variant->name)];
    pv.shape = to_string(o.variant->shape);
    ++pv.cases;
    switch (o.agreement) {
      case Agreement::agrees: ++pv.agree; break;
      case Agreement::cannot_tell: ++pv.cannot_tell; break;
      case Agreement::wrong: ++pv.wrong; break;
    }
    if (o.agreement != Agreement::agrees)
      ++pv.confusion[std::string(to_string(exact.cls)) + "->" + std::string(to_string(o.hit.cls))];
    if (o.ulp) pv.ulps.push_back(*o.ulp);
  }
}

void CheckSummary::print_table(std::ostream& out) const {
  out << std::left << std::setw(17) << "variant" << std::setw(10) << "shape" << std::right << std::setw(9)
      << "cases" << std::setw(9) << "agree" << std::setw(9) << "wrong" << std::setw(13) << "cannot-tell"
      << std::setw(12) << "ulp-median" << std::setw(21) << "ulp-p99" << std::setw(21) << "ulp-max"
      << "  disagreements (exact->variant)\n";
  for (const auto& [name, pv] : variants_) {
    std::string kinds;
    for (const auto& [k, n] : pv.confusion) kinds += (kinds.empty() ? "" : ", ") + k + " " + std::to_string(n);
    out << std::left << std::setw(17) << name << std::setw(10) << pv.shape << std::right << std::setw(9)
        << pv.cases << std::setw(9) << pv.agree << std::setw(9) << pv.wrong << std::setw(13) << pv.cannot_tell
        << std::setw(12) << quantile(pv.ulps, 0.5) << std::setw(21) << quantile(pv.ulps, 0.99) << std::setw(21)
        << quantile(pv.ulps, 1.0) << "  " << (kinds.empty() ? "-" : kinds) << "\n";
  }
}

json CheckSummary::to_json() const {
  json j = json::object();
  for (const auto& [name, pv] : variants_) {
    j[name] = {{"shape", pv.shape},
               {"cases", pv.cases},
               {"agree", pv.agree},
               {"wrong", pv.wrong},
               {"cannot_tell", pv.cannot_tell},
               {"disagreements", pv.confusion},
               {"ulp", {{"count", pv.ulps.size()},
                        {"median", quantile(pv.ulps, 0.5)},
                        {"p99", quantile(pv.ulps, 0.99)},
                        {"max", quantile(pv.ulps, 1.0)}}}};
  }
  return j;
}

}  // namespace rayproof
