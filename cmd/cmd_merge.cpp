// rayproof merge: the shards of one campaign combined into what the unsharded campaign tallies.
#include <algorithm>
#include <array>
#include <charconv>
#include <optional>
#include <fstream>
#include <iostream>
#include <set>
#include <sstream>

#include "commands.h"
#include "rayproof/core/atomic_file.h"
#include "rayproof/core/casefile.h"
#include "rayproof/core/mesh_case.h"
#include "rayproof/fuzz/campaign.h"
#include "rayproof/fuzz/tracer_campaign.h"

namespace rayproof::cli {

namespace {

struct MergeOptions {
  std::vector<std::string> findings, summaries;
  std::string output, summary, format = "table";
};

// A finding's place in its campaign: its family × construction × shape pair's place in the
// campaign's order (CampaignOrder), family and shape as the id names them, the seed, the index.
struct FindingKey {
  std::array<std::size_t, 2> pair_rank{0, 0};
  std::string family, shape;
  std::uint64_t seed = 0, index = 0;
  std::string tracer;  // mesh findings (tracer.md): "family[-any]/seed/index/tracer"
  auto operator<=>(const FindingKey&) const = default;
};

std::uint64_t id_number(const std::string& text, const std::string& id, const std::string& path, long line) {
  std::uint64_t n = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), n);
  if (text.empty() || ec != std::errc() || end != text.data() + text.size())
    throw std::runtime_error(printable(path) + ":" + std::to_string(line) + ": id '" + printable_prefix(id, 80) +
                             "': '" + printable_prefix(text, 40) + "' is not a whole number below 2^64");
  return n;
}

std::vector<std::string> id_parts(const std::string& id) {
  std::vector<std::string> parts;
  std::stringstream ss(id);
  for (std::string p; std::getline(ss, p, '/');) parts.push_back(p);
  return parts;
}

FindingKey key_of(const Case& c, const std::string& path, long line) {
  // ids are "family/shape/seed/index" (fuzz/campaign.cpp)
  const std::vector<std::string> parts = id_parts(c.id);
  if (parts.size() != 4)
    throw std::runtime_error(printable(path) + ":" + std::to_string(line) + ": id '" + printable_prefix(c.id, 80) +
                             "' is not a campaign finding's");
  return {{0, 0}, parts[0], parts[1], id_number(parts[2], c.id, path, line), id_number(parts[3], c.id, path, line)};
}

FindingKey mesh_key_of(const std::string& id, const std::string& path, long line) {
  const std::vector<std::string> parts = id_parts(id);
  if (parts.size() != 4)
    throw std::runtime_error(printable(path) + ":" + std::to_string(line) + ": id '" + printable_prefix(id, 80) +
                             "' is not a tracer campaign finding's");
  return {{0, 0}, parts[0], "", id_number(parts[1], id, path, line), id_number(parts[2], id, path, line), parts[3]};
}

// The order a campaign writes its pairs in (fuzz/campaign.cpp): each family as listed, its exact
// construction then its full one, and within it each shape as listed. From the summaries'
// campaign when given, else rayproof's own order of families and shapes. Unknown names go last.
struct CampaignOrder {
  std::vector<std::string> families, constructions, shapes;
  CampaignOrder() {
    for (fuzz::Family f : fuzz::kAllFamilies) families.emplace_back(to_string(f));
    constructions = {"exact", "full"};
    for (ShapeKind k : kAllShapeKinds) shapes.emplace_back(to_string(k));
  }
  explicit CampaignOrder(const json& campaign) : CampaignOrder() {
    auto list = [&](const char* key, std::vector<std::string>& into) {
      if (campaign.contains(key) && campaign.at(key).is_array() && !campaign.at(key).empty())
        into = campaign.at(key).get<std::vector<std::string>>();
    };
    list("families", families), list("constructions", constructions), list("shapes", shapes);
  }
  static std::size_t rank(const std::vector<std::string>& list, const std::string& name) {
    return static_cast<std::size_t>(std::find(list.begin(), list.end(), name) - list.begin());
  }
  std::array<std::size_t, 2> of(const std::string& family_label, const std::string& shape) const {
    const bool full = family_label.ends_with("-full");
    const std::string family = full ? family_label.substr(0, family_label.size() - 5) : family_label;
    const std::size_t construction = rank(constructions, full ? "full" : "exact");
    return {rank(families, family) * (constructions.size() + 1) + construction, rank(shapes, shape)};
  }
};

json read_summary_json(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error(path + ": cannot open");
  std::stringstream text;
  text << in.rdbuf();
  try {
    return parse_json_text(text.str());
  } catch (const std::exception& e) {
    throw std::runtime_error(printable(path) + ": not a campaign summary: " + printable(e.what()));
  }
}

// A summary's report, or an error naming the file and the field that is impossible.
template <class Report>
Report report_of(const json& j, const std::string& path, const char* what) {
  try {
    return Report::from_json(j);
  } catch (const FieldError& e) {
    throw std::runtime_error(printable(path) + ": not a " + what + " summary: field '" + e.field +
                             "': " + printable(e.what()));
  } catch (const std::exception& e) {
    throw std::runtime_error(printable(path) + ": not a " + what + " summary: " + printable(e.what()));
  }
}

int run_merge(const MergeOptions& o) {
  if (o.findings.empty() && o.summaries.empty())
    throw CLI::ValidationError("merge", "name the shards: --findings FILES and/or --summaries FILES");
  std::vector<std::string> inputs = o.findings;
  inputs.insert(inputs.end(), o.summaries.begin(), o.summaries.end());
  refuse_output_over_input(o.output, inputs);
  refuse_output_over_input(o.summary, inputs);
  std::unique_ptr<AtomicFile> out, summary_out;  // opened before the work
  if (!o.output.empty()) out = std::make_unique<AtomicFile>(o.output);
  if (!o.summary.empty()) summary_out = std::make_unique<AtomicFile>(o.summary);

  fuzz::CampaignReport merged;
  fuzz::TracerCampaignReport merged_tracers;
  bool tracers = false;  // the shards are of a tracer campaign (their summaries say "kind": "tracers")
  std::uint64_t tracer_findings_summarized = 0, findings_read = 0;
  std::map<std::string, std::set<std::string>> stopped_in;  // tracer → the shards it crashed or hung in
  std::vector<std::pair<std::string, fuzz::ShardOf>> shards;
  bool variants = false;
  for (const std::string& path : o.summaries) {
    const json j = read_summary_json(path);
    if (j.is_object() && j.value("kind", "") == "tracers") {
      tracers = true;
      const auto shard = report_of<fuzz::TracerCampaignReport>(j, path, "tracer campaign");
      shards.emplace_back(path, shard.shard_of);
      merged_tracers.merge(shard);
      tracer_findings_summarized += shard.findings_written;
      for (const auto& [k, t] : shard.tallies)
        if (t.count(TraceKind::crash) + t.count(TraceKind::timeout) + t.count(TraceKind::out_of_memory) > 0)
          stopped_in[k.name].insert(path);
      continue;
    }
    variants = true;
    const auto shard = report_of<fuzz::CampaignReport>(j, path, "campaign");
    shards.emplace_back(path, shard.shard_of);
    for (const auto& [k, t] : shard.tallies) merged.tallies[k].merge(t);
    for (const auto& [k, s] : shard.seconds) merged.seconds[k] += s;
    for (const auto& [k, s] : shard.shrink_seconds) merged.shrink_seconds[k] += s;
    merged.findings_unshrunk += shard.findings_unshrunk;
    for (const auto& [k, n] : shard.cases) merged.cases[k] += n;
    merged.shard_of = {shard.shard_of.campaign, 0, 1};  // merged: the whole of that campaign
  }
  if (tracers && variants)
    throw std::runtime_error("merge: tracer and variant campaign summaries cannot be merged together");
  fuzz::check_one_campaign(shards);  // one campaign, each shard once, none missing
  // With summaries, every finding must come from their campaign's seed.
  std::optional<std::uint64_t> seed;
  if (!shards.empty() && shards.front().second.campaign.contains("seed"))
    seed = read_count(shards.front().second.campaign.at("seed"), "campaign.seed");
  const CampaignOrder order =
      shards.empty() || tracers ? CampaignOrder() : CampaignOrder(shards.front().second.campaign);
  auto of_campaign = [&](FindingKey k, const std::string& path, long line) {
    if (seed && k.seed != *seed)
      throw std::runtime_error(printable(path) + ":" + std::to_string(line) + ": a finding of seed " +
                               std::to_string(k.seed) + ", but the summaries are of seed " + std::to_string(*seed));
    if (k.tracer.empty()) k.pair_rank = order.of(k.family, k.shape);
    return k;
  };
  // Deduplicated, in campaign order; each with whether found.level is "rounding".
  std::map<FindingKey, std::pair<std::string, bool>> findings;
  auto rounding_level = [](const json& found) {
    return found.is_object() && found.contains("level") && found.at("level") == "rounding";
  };
  long bad = 0;
  for (const std::string& path : o.findings) {
    std::ifstream in(path, std::ios::binary);
    if (!in) throw std::runtime_error(path + ": cannot open");
    long line = 0;
    for (std::string text; std::getline(in, text);) {
      ++line;
      if (text.find_first_not_of(" \t\r") == std::string::npos) continue;
      try {
        if (text.find("\"mesh\"") != std::string::npos) {
          const json j = parse_json_text(text);
          if (is_mesh_case(j)) {
            const MeshCase c = read_mesh_case(j);
            findings.emplace(of_campaign(mesh_key_of(c.id, path, line), path, line),
                             std::pair{text, rounding_level(c.found)});
            ++findings_read;
            continue;
          }
        }
        const Case c = parse_case(text);
        findings.emplace(of_campaign(key_of(c, path, line), path, line), std::pair{text, rounding_level(c.found)});
        ++findings_read;
      } catch (const json::parse_error& e) {
        ++bad;
        std::cerr << "rayproof: " << CaseError{path, line, "", std::string("malformed JSON: ") + e.what()}.to_string()
                  << "\n";
      } catch (const FieldError& e) {
        ++bad;
        std::cerr << "rayproof: " << CaseError{path, line, e.field, e.what()}.to_string() << "\n";
      }
    }
  }
  // A tracer campaign's shards said how many findings each wrote: a findings file given twice
  // or left out shows (issue 42).
  if (tracers && !o.findings.empty() && bad == 0) {
    if (findings_read != findings.size())
      throw std::runtime_error("merge: " + std::to_string(findings_read - findings.size()) +
                               " findings appear twice (a findings file given twice?)");
    if (findings.size() != tracer_findings_summarized)
      throw std::runtime_error("merge: the summaries say " + std::to_string(tracer_findings_summarized) +
                               " findings were written, the findings files hold " + std::to_string(findings.size()) +
                               " (a shard's findings file missing?)");
  }
  merged.findings_written = merged_tracers.findings_written = findings.size();
  if (out) {  // bug-level findings before rounding-level ones (verdicts.md §4), each in campaign order
    for (const bool rounding : {false, true})
      for (const auto& [k, finding] : findings)
        if (finding.second == rounding) out->stream() << finding.first << "\n";
    out->commit();
  }
  if (tracers) fuzz::print_tracer_report(merged_tracers, *table_format_from_string(o.format), std::cout);
  for (const auto& [name, paths] : stopped_in)  // README: crash budgets are per shard
    if (paths.size() > 1)
      std::cerr << "note: " << printable(name) << " stopped (crash or timeout) in " << paths.size()
                << " shards: each shard stops a tracer at its own first crash, the unsharded campaign at the first of "
                   "all, so the merged counts hold up to "
                << paths.size() << " crashes and the rays judged after the first\n";
    else
      fuzz::print_report(merged, 1, *table_format_from_string(o.format), std::cerr);
  if (summary_out) {
    summary_out->stream() << json_text(tracers ? merged_tracers.to_json() : merged.to_json(), 2) << "\n";
    summary_out->commit();
  }
  std::cerr << "rayproof merge: " << o.summaries.size() << " summaries, " << findings.size() << " findings from "
            << o.findings.size() << " files\n";
  return bad > 0 ? 1 : 0;
}

}  // namespace

void add_merge_command(CLI::App& app, int& exit_code) {
  auto opts = std::make_shared<MergeOptions>();
  auto* cmd =
      app.add_subcommand("merge", "Combine the shards of a campaign: tallies summed, findings deduplicated in order");
  cmd->add_option("--findings", opts->findings, "the shards' findings files")->expected(1, -1);
  cmd->add_option("--summaries", opts->summaries, "the shards' --summary files")->expected(1, -1);
  cmd->add_option("-o,--output", opts->output, "merged findings (JSON Lines)");
  cmd->add_option("--summary", opts->summary, "merged summary (JSON)");
  add_format_flag(cmd, opts->format);
  cmd->callback([opts, &exit_code] { exit_code = run_merge(*opts); });
}

}  // namespace rayproof::cli
