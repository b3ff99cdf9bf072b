#include "rayproof/verify/report.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace rayproof {

std::optional<TableFormat> table_format_from_string(std::string_view s) {
  if (s == "table") return TableFormat::table;
  if (s == "markdown") return TableFormat::markdown;
  if (s == "json") return TableFormat::json;
  return std::nullopt;
}

double bits_of_error(std::uint64_t ulps) { return std::log2(static_cast<double>(ulps) + 1); }

json bits_json(const Tally& t) { return bits_json(t.ulps); }
json bits_json(const UlpHistogram& ulps) {
  auto round1 = [](double x) { return std::round(x * 10) / 10; };
  return {{"p50", round1(bits_of_error(ulps.quantile(0.5)))},
          {"p99", round1(bits_of_error(ulps.quantile(0.99)))},
          {"max", round1(bits_of_error(ulps.max()))}};
}

json check_summary_json(ShapeKind shape, const Tally& t) {
  json j = t.to_json();
  j.erase("shared_edge_holes");  // not in check's summary (one case is no pair)
  j.erase("ulp");
  j["shape"] = std::string(to_string(shape));
  j["ulp"] = {{"count", t.ulps.count()},
              {"median", t.ulps.quantile(0.5)},
              {"p99", t.ulps.quantile(0.99)},
              {"max", t.ulps.max()}};
  j["bits"] = bits_json(t);
  return j;
}

std::string disagreement_kinds(const Tally& t, size_t top) {
  std::vector<std::pair<std::uint64_t, std::string>> kinds;
  for (const auto& [kind, n] : t.confusion) kinds.push_back({n, kind.to_string()});
  // Ties in the order of the written names, as a summary lists them.
  std::sort(kinds.begin(), kinds.end(), [](const auto& a, const auto& b) { return a.second < b.second; });
  std::stable_sort(kinds.begin(), kinds.end(), [](const auto& a, const auto& b) { return a.first > b.first; });
  std::string out;
  for (size_t i = 0; i < kinds.size() && i < top; ++i)
    out += (i ? ", " : "") + kinds[i].second + " " + std::to_string(kinds[i].first);
  if (kinds.size() > top) out += ", +" + std::to_string(kinds.size() - top) + " more";
  return out.empty() ? "-" : out;
}

namespace {

std::string bits_cell(const Tally& t, double q) {
  if (t.ulps.count() == 0) return "-";
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.1f", bits_of_error(q >= 1 ? t.ulps.max() : t.ulps.quantile(q)));
  return buf;
}

// What external code failed to answer, and a float variant's error in its own ulps, beside the
// disagreements (plugin.md): "crashed (stopped); 4657 not representable in float; float ulps p99 3".
std::string notes_of(const Tally& t) {
  std::string notes = disagreement_kinds(t);
  auto add = [&](std::uint64_t n, const std::string& what) {
    if (n == 0) return;
    notes = (notes == "-" ? "" : notes + "; ") + std::to_string(n) + " " + what;
  };
  add(t.crashes, "crash");
  add(t.timeouts, "timeout");
  add(t.protocol_errors, "protocol error (variant stopped)");
  add(t.plugin_errors, "plugin errors");
  add(t.not_representable, "not representable in float");
  if (t.ulps_own.count() > 0)
    notes = (notes == "-" ? "" : notes + "; ") + "float ulps p99 " + std::to_string(t.ulps_own.quantile(0.99)) +
            ", max " + std::to_string(t.ulps_own.max());
  return notes;
}

// `levels`: the bugs and rounding-level columns (verdicts.md §4: bugs first), where a row has them.
std::vector<std::string> cells_of(const TallyRow& r, bool levels) {
  const Tally& t = r.tally;
  std::vector<std::string> c;
  if (!r.family.empty()) c.push_back(r.family);
  for (const std::string& x : {r.variant, std::string(to_string(r.shape)), std::to_string(t.cases)}) c.push_back(x);
  if (levels) {
    c.push_back(t.tolerance_ulps ? std::to_string(t.bug_count()) : "-");
    c.push_back(t.tolerance_ulps ? std::to_string(t.rounding_count()) : "-");
  }
  for (const std::string& x :
       {std::to_string(t.agree), std::to_string(t.wrong), std::to_string(t.cannot_tell),
        std::to_string(t.shared_edge_holes), bits_cell(t, 0.5), bits_cell(t, 0.99), bits_cell(t, 1.0), notes_of(t)})
    c.push_back(x);
  return c;
}

// The screen's row (at most ~120 columns): every case in one column — agree + wrong + n/t make
// `cases`, n/r and failed are the cases not judged — the commonest disagreements and the bits'
// quantiles left to markdown and JSON (and to the examples printed after the table).
std::vector<std::string> screen_cells_of(const TallyRow& r, bool levels) {
  const Tally& t = r.tally;
  std::vector<std::string> c;
  if (!r.family.empty()) c.push_back(r.family);
  for (std::uint64_t n : {t.cases, t.agree, t.wrong, t.cannot_tell}) c.push_back(std::to_string(n));
  c.insert(c.begin() + (r.family.empty() ? 0 : 1), {r.variant, std::string(to_string(r.shape))});
  if (levels) {
    c.push_back(t.tolerance_ulps ? std::to_string(t.bug_count()) : "-");
    c.push_back(t.tolerance_ulps ? std::to_string(t.rounding_count()) : "-");
  }
  for (const std::string& x : {std::to_string(t.shared_edge_holes), std::to_string(t.not_representable),
                               std::to_string(t.failures()), bits_cell(t, 1.0)})
    c.push_back(x);
  return c;
}

void write_text(const std::vector<std::vector<std::string>>& lines, bool markdown, std::ostream& out,
                const char* separator = "  ") {
  std::vector<size_t> width(lines[0].size(), 0);
  for (const auto& l : lines)
    for (size_t i = 0; i < l.size(); ++i) width[i] = std::max(width[i], l[i].size());
  const size_t text_columns = lines[0][0] == "family" ? 3 : 2;  // left-aligned; numbers right-aligned
  for (size_t n = 0; n < lines.size(); ++n) {
    std::string row = markdown ? "|" : "";
    for (size_t i = 0; i < lines[n].size(); ++i) {
      const bool last = i + 1 == lines[n].size(), left = i < text_columns || last;
      const std::string pad(last && !markdown ? 0 : width[i] - lines[n][i].size(), ' ');
      row += (markdown ? " " : (i ? separator : "")) + (left ? lines[n][i] + pad : pad + lines[n][i]) +
             (markdown ? " |" : "");
    }
    out << row << "\n";
    if (markdown && n == 0) {
      out << "|";
      for (size_t i = 0; i < width.size(); ++i) out << (i < text_columns || i + 1 == width.size() ? "---|" : "---:|");
      out << "\n";
    }
  }
}

}  // namespace

namespace {
void sort_rows(std::vector<TallyRow>& rows, const std::vector<std::string>& families) {
  auto family_rank = [&](const std::string& f) {
    return std::find(families.begin(), families.end(), f) - families.begin();
  };
  std::stable_sort(rows.begin(), rows.end(), [&](const TallyRow& a, const TallyRow& b) {
    if (a.shape != b.shape) return a.shape < b.shape;
    if (a.variant != b.variant) return a.variant < b.variant;
    return family_rank(a.family) < family_rank(b.family);
  });
}
}  // namespace

json tally_table_json(std::vector<TallyRow> rows, const std::vector<std::string>& families) {
  sort_rows(rows, families);
  json j = json::array();
  for (const TallyRow& r : rows) {
    json row = r.tally.to_json();
    row.erase("ulp");
    row["ulp"] = {{"count", r.tally.ulps.count()},
                  {"p50", r.tally.ulps.quantile(0.5)},
                  {"p99", r.tally.ulps.quantile(0.99)},
                  {"max", r.tally.ulps.max()}};
    if (!r.family.empty()) row["family"] = r.family;
    row["variant"] = r.variant;
    row["shape"] = std::string(to_string(r.shape));
    j.push_back(row);
  }
  return j;
}

void write_tally_table(std::vector<TallyRow> rows, TableFormat format, std::ostream& out,
                       const std::vector<std::string>& families) {
  if (format == TableFormat::json) {
    out << json_text(tally_table_json(std::move(rows), families), 2) << "\n";
    return;
  }
  sort_rows(rows, families);
  const bool with_family = !rows.empty() && !rows[0].family.empty();
  const bool levels =
      std::any_of(rows.begin(), rows.end(), [](const TallyRow& r) { return r.tally.tolerance_ulps.has_value(); });
  if (format == TableFormat::table) {
    std::vector<std::vector<std::string>> lines;
    std::vector<std::string> header = {"variant", "shape", "cases", "agree", "wrong", "n/t"};
    if (levels) header.insert(header.end(), {"bugs", "r:round"});
    header.insert(header.end(), {"holes", "n/r", "failed", "bits-max"});
    if (with_family) header.insert(header.begin(), "family");
    lines.push_back(header);
    for (const TallyRow& r : rows) lines.push_back(screen_cells_of(r, levels));
    // The last column is left-aligned by write_text; bits-max is a number: pad it here.
    for (auto& l : lines)
      l.back() = std::string(std::max<std::size_t>(8, l.back().size()) - l.back().size(), ' ') + l.back();
    write_text(lines, false, out, " ");
    out << "agree + wrong + n/t (cannot tell) = cases; n/r (not representable in float) and failed (crashes, "
           "timeouts,\n"
           "plugin errors) are cases not judged;"
        << (levels ? " bugs + r:round = wrong + n/t: r:round within --tolerance-ulps, with a witness\n"
                     "the exact oracle accepted (verdicts.md);"
                   : "")
        << " holes at shared edges; bits-max: the worst t error, log2(ulps + 1).\n"
           "--format markdown or json adds the commonest disagreements and the bits' p50 and p99.\n";
    return;
  }
  std::vector<std::vector<std::string>> lines;
  std::vector<std::string> header = {"variant",
                                     "shape",
                                     "cases",
                                     "agree",
                                     "wrong",
                                     "cannot-tell",
                                     "holes",
                                     "bits-p50",
                                     "bits-p99",
                                     "bits-max",
                                     "commonest disagreements (exact->variant)"};
  if (levels) header.insert(header.begin() + 3, {"bugs", "r:rounding"});
  if (with_family) header.insert(header.begin(), "family");
  lines.push_back(header);
  for (const TallyRow& r : rows) lines.push_back(cells_of(r, levels));
  write_text(lines, format == TableFormat::markdown, out);
  std::string legend = "t error in bits, log2(ulps + 1), over the cases whose class agrees (0: correctly rounded)";
  if (levels)
    legend +=
        "; bugs: disagreements whose backward error exceeds --tolerance-ulps (or has no witness), "
        "r:rounding: those within it, each with a witness the exact oracle accepted (verdicts.md)";
  out << (format == TableFormat::markdown ? "\n" + legend + ".\n" : legend + "\n");
}

}  // namespace rayproof
