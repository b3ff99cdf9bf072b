#include "rayproof/campaign.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <sstream>
#include <thread>

#include "rayproof/atomic_file.h"
#include "rayproof/casefile.h"
#include "rayproof/compare.h"
#include "rayproof/oracle.h"
#include "rayproof/shrink.h"

namespace rayproof::fuzz {

// ----------------------------------------------------------------------------- histogram
int UlpHistogram::bucket(std::uint64_t ulp) {
  if (ulp < 128) return static_cast<int>(ulp);
  const int log2 = 63 - __builtin_clzll(ulp);               // ≥ 7
  const int sub = static_cast<int>((ulp >> (log2 - 3)) & 7);  // next three bits
  return 128 + (log2 - 7) * 8 + sub;
}
std::uint64_t UlpHistogram::lower_bound(int b) {
  if (b < 128) return static_cast<std::uint64_t>(b);
  const int log2 = (b - 128) / 8 + 7, sub = (b - 128) % 8;
  return (std::uint64_t(8 + sub)) << (log2 - 3);
}
void UlpHistogram::add(std::uint64_t ulp) {
  ++buckets_[bucket(ulp)];
  ++count_;
  max_ = std::max(max_, ulp);
}
void UlpHistogram::merge(const UlpHistogram& o) {
  for (const auto& [b, n] : o.buckets_) buckets_[b] += n;
  count_ += o.count_;
  max_ = std::max(max_, o.max_);
}
std::uint64_t UlpHistogram::quantile(double q) const {
  if (count_ == 0) return 0;
  const std::uint64_t rank = std::max<std::uint64_t>(1, static_cast<std::uint64_t>(std::ceil(q * count_)));
  std::uint64_t seen = 0;
  for (const auto& [b, n] : buckets_) {
    seen += n;
    if (seen >= rank) return std::min(lower_bound(b), max_);
  }
  return max_;
}
json UlpHistogram::to_json() const {
  json b = json::object();
  for (const auto& [k, n] : buckets_) b[std::to_string(k)] = n;
  return {{"count", count_}, {"max", max_}, {"buckets", b}};
}
UlpHistogram UlpHistogram::from_json(const json& j) {
  UlpHistogram h;
  h.count_ = j.at("count");
  h.max_ = j.at("max");
  for (auto it = j.at("buckets").begin(); it != j.at("buckets").end(); ++it) h.buckets_[std::stoi(it.key())] = it.value();
  return h;
}

// ----------------------------------------------------------------------------- tallies
void Tally::merge(const Tally& o) {
  cases += o.cases, agree += o.agree, wrong += o.wrong, cannot_tell += o.cannot_tell;
  shared_edge_holes += o.shared_edge_holes;
  for (const auto& [k, n] : o.confusion) confusion[k] += n;
  ulps.merge(o.ulps);
}
json Tally::to_json() const {
  return {{"cases", cases}, {"agree", agree}, {"wrong", wrong}, {"cannot_tell", cannot_tell},
          {"shared_edge_holes", shared_edge_holes}, {"disagreements", confusion}, {"ulp", ulps.to_json()}};
}
Tally Tally::from_json(const json& j) {
  Tally t;
  t.cases = j.at("cases"), t.agree = j.at("agree"), t.wrong = j.at("wrong"), t.cannot_tell = j.at("cannot_tell");
  t.shared_edge_holes = j.at("shared_edge_holes");
  t.confusion = j.at("disagreements").get<std::map<std::string, std::uint64_t>>();
  t.ulps = UlpHistogram::from_json(j.at("ulp"));
  return t;
}
json CampaignReport::to_json() const {
  json t = json::object();
  for (const auto& [k, v] : tallies) t[k] = v.to_json();
  return {{"tallies", t}, {"seconds", seconds}, {"cases", cases}, {"findings_written", findings_written}};
}
CampaignReport CampaignReport::from_json(const json& j) {
  CampaignReport r;
  for (auto it = j.at("tallies").begin(); it != j.at("tallies").end(); ++it) r.tallies[it.key()] = Tally::from_json(it.value());
  r.seconds = j.at("seconds").get<std::map<std::string, double>>();
  r.cases = j.at("cases").get<std::map<std::string, std::uint64_t>>();
  r.findings_written = j.at("findings_written");
  return r;
}

namespace {

std::string key(std::string_view a, std::string_view b) { return std::string(a) + "\t" + std::string(b); }

json fingerprint(const CampaignOptions& o) {
  json f = json::array(), s = json::array();
  for (Family x : o.families) f.push_back(std::string(to_string(x)));
  for (ShapeKind x : o.shapes) s.push_back(std::string(to_string(x)));
  return {{"families", f}, {"shapes", s}, {"count", o.count}, {"seed", o.seed}, {"shard", o.shard},
          {"shards", o.shards}, {"rule", std::string(to_string(o.rule))}, {"shrink", o.shrink},
          {"max_findings", o.max_findings}, {"batch", o.batch}};
}

// Where the campaign stands after the last completed batch.
struct Checkpoint {
  size_t pair = 0;
  std::uint64_t next = 0;  // first case index not yet done in `pair`
  bool pair_started = false;
  std::uint64_t findings_in_pair = 0;
  std::uintmax_t findings_bytes = 0;
  CampaignReport report;
};

void save(const std::string& path, const CampaignOptions& o, const Checkpoint& c) {
  AtomicFile f(path);
  f.stream() << json{{"fingerprint", fingerprint(o)}, {"pair", c.pair}, {"next", c.next},
                     {"pair_started", c.pair_started}, {"findings_in_pair", c.findings_in_pair},
                     {"findings_bytes", c.findings_bytes}, {"report", c.report.to_json()}}
                    .dump()
             << "\n";
  f.commit();
}

Checkpoint load(const std::string& path, const CampaignOptions& o) {
  std::ifstream in(path);
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw std::runtime_error(path + ": unreadable checkpoint: " + e.what());
  }
  if (j.at("fingerprint") != fingerprint(o))
    throw std::runtime_error(path + ": checkpoint belongs to a campaign with other options: " + j.at("fingerprint").dump());
  Checkpoint c;
  c.pair = j.at("pair"), c.next = j.at("next"), c.pair_started = j.at("pair_started");
  c.findings_in_pair = j.at("findings_in_pair"), c.findings_bytes = j.at("findings_bytes");
  c.report = CampaignReport::from_json(j.at("report"));
  return c;
}

// This shard's index range, with even bounds so grazing triangle pairs stay together.
std::pair<std::uint64_t, std::uint64_t> shard_range(const CampaignOptions& o) {
  auto bound = [&](unsigned s) -> std::uint64_t {
    if (s >= o.shards) return o.count;
    const std::uint64_t b = static_cast<std::uint64_t>((static_cast<unsigned __int128>(o.count) * s) / o.shards);
    return b & ~std::uint64_t(1);
  };
  return {bound(o.shard), bound(o.shard + 1)};
}

struct Finding {
  std::uint64_t index;
  GeneratedCase generated;
  const Variant* first_disagreeing;
};

struct Worker {
  Oracle oracle;
  std::map<std::string, Tally> tallies;  // by variant
  std::vector<Finding> findings;
};

json variant_answers(const std::vector<const Variant*>& variants, Oracle& oracle, const Case& c, HitRule rule,
                     bool only_disagreeing) {
  const Verdict exact = oracle.judge(c.ray, c.shape, rule);
  json out = json::object();
  for (const Variant* v : variants) {
    const VariantOutcome o = compare_variant(*v, exact, c.ray, c.shape, rule);
    if (only_disagreeing && o.agreement == Agreement::agrees) continue;
    out[std::string(v->name)] = {{"class", std::string(to_string(o.hit.cls))},
                                 {"t", o.hit.has_t() ? json(hex_double(o.hit.t)) : json(nullptr)},
                                 {"ulp", o.ulp ? json(*o.ulp) : json(nullptr)}};
  }
  return out;
}

}  // namespace

CampaignReport run_campaign(const CampaignOptions& o) {
  if (o.families.empty() || o.shapes.empty()) throw std::runtime_error("no family or shape chosen");
  if (o.shards == 0 || o.shard >= o.shards) throw std::runtime_error("--shard must be i/n with i < n");
  const std::string checkpoint_path = o.output + ".checkpoint";
  std::vector<std::pair<Family, ShapeKind>> pairs;
  for (Family f : o.families)
    for (ShapeKind s : o.shapes) pairs.push_back({f, s});
  const auto [lo, hi] = shard_range(o);
  const std::uint64_t batch = std::max<std::uint64_t>(2, o.batch & ~std::uint64_t(1));

  Checkpoint cp;
  if (o.resume && std::filesystem::exists(checkpoint_path)) {
    cp = load(checkpoint_path, o);
    if (!std::filesystem::exists(o.output)) throw std::runtime_error(o.output + ": findings file missing, cannot resume");
    std::filesystem::resize_file(o.output, cp.findings_bytes);  // drop a batch written after the checkpoint
  } else {
    if (o.resume && std::filesystem::exists(o.output))
      throw std::runtime_error(checkpoint_path + ": no checkpoint to resume from");
    std::ofstream(o.output, std::ios::trunc);
  }
  std::ofstream out(o.output, std::ios::app | std::ios::binary);
  if (!out) throw std::runtime_error(o.output + ": cannot write");

  const int threads = std::max(1, o.threads);
  std::vector<Worker> workers(threads);
  long batches_done = 0;
  for (; cp.pair < pairs.size(); ++cp.pair, cp.pair_started = false, cp.findings_in_pair = 0) {
    const auto [family, shape] = pairs[cp.pair];
    const auto variants = variants_for(shape);
    const std::string pair_key = key(to_string(family), to_string(shape));
    if (!cp.pair_started) cp.next = lo, cp.pair_started = true;
    const bool pairs_of_triangles = family == Family::grazing && shape == ShapeKind::triangle;
    for (std::uint64_t start = cp.next; start < hi; start += batch) {
      const auto t0 = std::chrono::steady_clock::now();
      const std::uint64_t end = std::min(hi, start + batch), n = end - start;
      std::vector<std::uint8_t> exact_hit(pairs_of_triangles ? n : 0), exact_front(exact_hit.size()),
          through_edge(exact_hit.size());
      std::vector<std::vector<std::uint8_t>> variant_hit(pairs_of_triangles ? variants.size() : 0,
                                                         std::vector<std::uint8_t>(n));
      auto work = [&](int w) {
        Worker& me = workers[w];
        me.tallies.clear();
        me.findings.clear();
        for (std::uint64_t i = start + n * w / threads; i < start + n * (w + 1) / threads; ++i) {
          GeneratedCase g = generate(family, shape, o.seed, i);
          const Verdict exact = me.oracle.judge(g.ray, g.shape, o.rule);
          const Variant* first = nullptr;
          for (size_t vi = 0; vi < variants.size(); ++vi) {
            const VariantOutcome r = compare_variant(*variants[vi], exact, g.ray, g.shape, o.rule);
            Tally& t = me.tallies[std::string(variants[vi]->name)];
            ++t.cases;
            if (r.agreement == Agreement::agrees) ++t.agree;
            else {
              (r.agreement == Agreement::wrong ? t.wrong : t.cannot_tell)++;
              ++t.confusion[std::string(to_string(exact.cls)) + "->" + std::string(to_string(r.hit.cls))];
              if (!first) first = variants[vi];
            }
            if (r.ulp) t.ulps.add(*r.ulp);
            if (pairs_of_triangles) variant_hit[vi][i - start] = r.hit.cls != HitClass::miss;
          }
          if (pairs_of_triangles) {
            exact_hit[i - start] = exact.cls != HitClass::miss;
            exact_front[i - start] = exact.front;
            // A ray through a shared vertex may rightly miss both: the rest of the fan is absent.
            through_edge[i - start] = g.detail.rfind("shared-edge", 0) == 0;
          }
          if (first) me.findings.push_back({i, std::move(g), first});
        }
      };
      {
        std::vector<std::thread> pool;
        for (int w = 1; w < threads; ++w) pool.emplace_back(work, w);
        work(0);
        for (auto& t : pool) t.join();
      }
      // Throughput counts generating and checking; shrinking findings is reported apart.
      const double check_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
      std::vector<Finding> findings;
      for (Worker& w : workers) {
        for (auto& [name, t] : w.tallies) cp.report.tallies[key(to_string(family), name)].merge(t);
        for (Finding& f : w.findings) findings.push_back(std::move(f));
      }
      // A hole: the ray crosses the surface through the shared edge (not a silhouette, where the
      // pair is seen folded, front of one and back of the other, and a miss is fair), the exact
      // ray meets the pair, and the variant misses both.
      if (pairs_of_triangles)
        for (std::uint64_t i = 0; i + 1 < n; i += 2) {
          const bool silhouette = exact_hit[i] && exact_hit[i + 1] && exact_front[i] != exact_front[i + 1];
          if (!through_edge[i] || silhouette || !(exact_hit[i] || exact_hit[i + 1])) continue;
          for (size_t vi = 0; vi < variants.size(); ++vi)
            if (!variant_hit[vi][i] && !variant_hit[vi][i + 1])
              ++cp.report.tallies[key(to_string(family), variants[vi]->name)].shared_edge_holes;
        }
      std::sort(findings.begin(), findings.end(), [](const Finding& a, const Finding& b) { return a.index < b.index; });
      const std::uint64_t room = o.max_findings > cp.findings_in_pair ? o.max_findings - cp.findings_in_pair : 0;
      if (findings.size() > room) findings.resize(room);

      // Shrink and format the findings in parallel; write them in index order.
      std::vector<std::string> lines(findings.size());
      auto format = [&](int w) {
        for (size_t k = w; k < findings.size(); k += threads) {
          const Finding& f = findings[k];
          Case c;
          c.id = std::string(to_string(family)) + "/" + std::string(to_string(shape)) + "/" + std::to_string(o.seed) +
                 "/" + std::to_string(f.index);
          c.ray = f.generated.ray;
          c.shape = f.generated.shape;
          Case original = c;
          if (o.shrink) c = shrink(c, *f.first_disagreeing, workers[w].oracle, o.rule);
          const Verdict exact = workers[w].oracle.judge(c.ray, c.shape, o.rule);
          c.expect = Expectation{exact.cls, exact.t};
          c.found = {{"family", std::string(to_string(family))},
                     {"seed", o.seed},
                     {"index", f.index},
                     {"detail", f.generated.detail},
                     {"rule", std::string(to_string(o.rule))},
                     {"disagreeing", variant_answers(variants, workers[w].oracle, c, o.rule, true)}};
          if (o.shrink && case_to_json(c)["ray"] != case_to_json(original)["ray"]) c.found["shrunk_from"] = case_to_json(original)["ray"];
          if (o.shrink && case_to_json(c)["shape"] != case_to_json(original)["shape"])
            c.found["shrunk_from_shape"] = case_to_json(original)["shape"];
          lines[k] = case_to_json(c).dump() + "\n";
        }
      };
      {
        std::vector<std::thread> pool;
        for (int w = 1; w < threads; ++w) pool.emplace_back(format, w);
        format(0);
        for (auto& t : pool) t.join();
      }
      for (const std::string& line : lines) out << line;
      out.flush();
      if (!out) throw std::runtime_error(o.output + ": write failed");
      cp.findings_in_pair += lines.size();
      cp.report.findings_written += lines.size();
      if (o.crash_after_batches >= 0 && ++batches_done > o.crash_after_batches) std::_Exit(3);  // testing hook
      cp.report.cases[pair_key] += n;
      cp.report.seconds[pair_key] += check_seconds;
      cp.next = end;
      cp.findings_bytes = std::filesystem::file_size(o.output);
      save(checkpoint_path, o, cp);
      if (o.progress) o.progress(pair_key, end - lo, hi - lo);
    }
  }
  save(checkpoint_path, o, cp);
  return cp.report;
}

void print_report(const CampaignReport& r, int threads, std::ostream& out) {
  out << std::left << std::setw(12) << "family" << std::setw(17) << "variant" << std::right << std::setw(10) << "cases"
      << std::setw(11) << "disagree%" << std::setw(9) << "wrong" << std::setw(13) << "cannot-tell" << std::setw(18)
      << "ulp-p50" << std::setw(21) << "ulp-p99" << std::setw(21) << "ulp-max" << std::setw(7) << "holes"
      << "  disagreements (exact->variant)\n";
  for (const auto& [k, t] : r.tallies) {
    const std::string family = k.substr(0, k.find('\t')), variant = k.substr(k.find('\t') + 1);
    std::string kinds;
    std::vector<std::pair<std::uint64_t, std::string>> sorted;
    for (const auto& [c, n] : t.confusion) sorted.push_back({n, c});
    std::sort(sorted.rbegin(), sorted.rend());
    for (size_t i = 0; i < sorted.size() && i < 4; ++i)
      kinds += (i ? ", " : "") + sorted[i].second + " " + std::to_string(sorted[i].first);
    char rate[32];
    std::snprintf(rate, sizeof rate, "%.4f", t.cases ? 100.0 * (t.wrong + t.cannot_tell) / t.cases : 0.0);
    out << std::left << std::setw(12) << family << std::setw(17) << variant << std::right << std::setw(10) << t.cases
        << std::setw(11) << rate << std::setw(9) << t.wrong << std::setw(13) << t.cannot_tell << std::setw(18)
        << t.ulps.quantile(0.5) << std::setw(21) << t.ulps.quantile(0.99) << std::setw(21) << t.ulps.max()
        << std::setw(7) << t.shared_edge_holes << "  " << (kinds.empty() ? "-" : kinds) << "\n";
  }
  for (const auto& [k, seconds] : r.seconds) {
    const std::uint64_t n = r.cases.at(k);
    out << "throughput " << k.substr(0, k.find('\t')) << "/" << k.substr(k.find('\t') + 1) << ": " << n << " cases checked in "
        << std::fixed << std::setprecision(2) << seconds << " s, " << std::setprecision(0)
        << (seconds > 0 ? n / seconds / threads : 0) << " cases/s per core (" << threads << " threads)\n"
        << std::defaultfloat;
  }
}

}  // namespace rayproof::fuzz
