#include "rayproof/fuzz/shard_of.h"

#include <map>
#include <stdexcept>

namespace rayproof::fuzz {

void ShardOf::write_to(json& summary) const {
  if (campaign.is_null()) return;  // a report still in progress (a checkpoint's) names no campaign yet
  summary["campaign"] = campaign;
  summary["shard"] = {{"index", shard}, {"count", shards}};
}

ShardOf ShardOf::read_from(const json& summary) {
  ShardOf s;
  if (!summary.contains("campaign") || summary.at("campaign").is_null()) return s;
  s.campaign = summary.at("campaign");
  if (!s.campaign.is_object()) throw FieldError("campaign", "expected an object");
  const json& shard = summary.contains("shard") ? summary.at("shard") : json();
  if (!shard.is_object()) throw FieldError("shard", "expected {\"index\": i, \"count\": n}");
  s.shard = read_count(shard.contains("index") ? shard.at("index") : json(), "shard.index");
  s.shards = read_count(shard.contains("count") ? shard.at("count") : json(), "shard.count");
  if (s.shards == 0 || s.shard >= s.shards) throw FieldError("shard", "needs 0 <= index < count");
  return s;
}

void check_one_campaign(const std::vector<std::pair<std::string, ShardOf>>& shards) {
  if (shards.empty()) return;
  const auto& [first_path, first] = shards.front();
  std::map<std::uint64_t, std::string> seen;  // shard index → the file that had it
  for (const auto& [path, s] : shards) {
    if (s.campaign.is_null())
      throw std::runtime_error(printable(path) +
                               ": the summary names no campaign (written before merge checked them?): "
                               "merge cannot tell what it belongs to; rerun the shard");
    if (s.campaign != first.campaign) {
      std::string differs;
      for (const auto& [key, value] : s.campaign.items())
        if (!first.campaign.contains(key) || first.campaign.at(key) != value)
          differs += (differs.empty() ? "" : ", ") + key + " " + json_text(value) + " vs " +
                     (first.campaign.contains(key) ? json_text(first.campaign.at(key)) : std::string("none"));
      throw std::runtime_error(printable(path) + ": another campaign than " + printable(first_path) + " (" +
                               printable_prefix(differs.empty() ? "a key is missing" : differs, 300) + ")");
    }
    if (s.shards != first.shards)
      throw std::runtime_error(printable(path) + ": shard " + std::to_string(s.shard) + " of " +
                               std::to_string(s.shards) + ", but " + printable(first_path) + " is one of " +
                               std::to_string(first.shards));
    const auto [it, fresh] = seen.emplace(s.shard, path);
    if (!fresh)
      throw std::runtime_error(printable(path) + ": shard " + std::to_string(s.shard) + " of " +
                               std::to_string(s.shards) + " again (also " + printable(it->second) + ")");
  }
  if (seen.size() != first.shards) {
    std::string missing;
    int listed = 0;
    for (std::uint64_t i = 0; i < first.shards && listed < 10; ++i)
      if (!seen.count(i)) missing += (listed++ ? ", " : "") + std::to_string(i);
    throw std::runtime_error("merge: shards " + missing + (first.shards - seen.size() > 10 ? ", …" : "") + " of " +
                             std::to_string(first.shards) + " are missing (" + std::to_string(seen.size()) + " given)");
  }
}

}  // namespace rayproof::fuzz
