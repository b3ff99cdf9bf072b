// Which campaign a summary belongs to and which share of it it holds (issue 26): a campaign's
// summary carries both, so that `merge` sums only the shards of one campaign, each exactly once.
#pragma once

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "rayproof/core/json_fields.h"

namespace rayproof::fuzz {

struct ShardOf {
  // What makes two runs the same campaign: seed, count, families, shapes or tracers, variants,
  // constructions, rule and rayproof's version. Null in summaries written before it existed.
  json campaign;
  std::uint64_t shard = 0, shards = 1;

  // {"campaign": …, "shard": {"index": i, "count": n}}, merged into a summary object.
  void write_to(json& summary) const;
  // From a summary: nothing when it has no "campaign"; a FieldError when it is malformed.
  static ShardOf read_from(const json& summary);
};

// Throws std::runtime_error naming the file unless the summaries are the shards of one campaign,
// each once, none missing. `shards`: {path, what the summary said}.
void check_one_campaign(const std::vector<std::pair<std::string, ShardOf>>& shards);

}  // namespace rayproof::fuzz
