// The audit's files: audit.json (docs/spec/audit.md's keys, plus compatible extras), the PNGs
// and report.html, one self-contained page.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "rayproof/core/atomic_file.h"
#include "rayproof/core/casefile.h"
#include "rayproof/core/json_fields.h"
#include "rayproof/studies/scene_audit.h"
#include "rayproof/studies/markup.h"
#include "rayproof/studies/svg.h"
#include "rayproof/verify/diagnose.h"

namespace rayproof::studies {

namespace {

using nlohmann::json;

// A variant's name as a file name: anything but letters, digits, '.', '_' and '-' becomes '_'.
std::string file_stem(std::string_view name) {
  std::string s(name);
  for (char& c : s)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-')) c = '_';
  if (s.empty() || s[0] == '.') s = "variant-" + s;
  return s;
}

// Each variant's file stem: STEM.png and STEM-diff.png (audit.md). Names chosen by users can
// collide (an exec variant "stable-diff" against built-in stable's diff image, a plugin named
// "exact" or "report"), so a stem whose files are taken gets "-2", "-3", … and audit.json names
// the files actually written: no file is ever overwritten by another variant's.
}  // namespace

std::vector<std::string> audit_file_stems(const SceneAudit& a) {
  std::set<std::string> taken = {"exact.png", "report.html", "audit.json", "headroom.svg"};
  std::vector<std::string> stems;
  for (const VariantAudit& va : a.variants) {
    const std::string base = file_stem(va.label);
    std::string stem = base;
    for (int k = 2; taken.count(stem + ".png") || taken.count(stem + "-diff.png"); ++k)
      stem = base + "-" + std::to_string(k);
    taken.insert(stem + ".png");
    taken.insert(stem + "-diff.png");
    stems.push_back(stem);
  }
  return stems;
}

namespace {

// The command that audits this scene again with the same variants and tracers, loading the same
// plugins, exec commands and tracer libraries (origins: "built-in", a library's path, "exec: CMD").
std::string reproduce_command(const SceneAudit& a, const std::string& scene_path) {
  std::vector<std::string> variants, tracers, loads;
  auto once = [](std::vector<std::string>& list, const std::string& item) {
    if (std::find(list.begin(), list.end(), item) == list.end()) list.push_back(item);
  };
  for (const VariantAudit& va : a.variants) {
    const bool exec = va.origin.rfind("exec: ", 0) == 0, library = va.origin.find('/') != std::string::npos && !exec;
    if (va.tracer) {
      once(tracers, va.name);
      if (exec)
        once(loads, "--tracer-exec " + shell_quoted(va.name + "=" + va.origin.substr(6)));
      else if (library)
        once(loads, "--tracer " + shell_quoted(va.origin));
    } else {
      once(variants, va.name);
      if (const std::string flags = va.variant ? loading_flags(*va.variant) : ""; !flags.empty()) once(loads, flags);
    }
  }
  auto joined = [](const std::vector<std::string>& list) {
    std::string out;
    for (const std::string& s : list) out += (out.empty() ? "" : ",") + s;
    return out;
  };
  std::string cmd = "rayproof audit " + shell_quoted(scene_path) + " -o DIR";
  if (!variants.empty()) cmd += " --variants " + joined(variants);
  if (!tracers.empty()) cmd += " --tracers " + joined(tracers);
  for (const std::string& l : loads) cmd += " " + l;
  if (a.headroom) cmd += " --headroom";
  return cmd;
}

}  // namespace

std::string cases_replay_command(const VariantAudit& va, const std::string& cases_file) {
  if (va.tracer) {  // the tracer loaded as the audit loaded it (reproduce_command's origins)
    std::string cmd = "rayproof check " + shell_quoted(cases_file) + " --tracers " + shell_quoted(va.name);
    if (va.origin.rfind("exec: ", 0) == 0)
      cmd += " --tracer-exec " + shell_quoted(va.name + "=" + va.origin.substr(6));
    else if (va.origin.find('/') != std::string::npos)
      cmd += " --tracer " + shell_quoted(va.origin);
    return cmd;
  }
  std::string cmd = "rayproof check " + shell_quoted(cases_file) + " --variants " + shell_quoted(va.name);
  if (const std::string flags = va.variant ? loading_flags(*va.variant) : ""; !flags.empty()) cmd += " " + flags;
  return cmd;
}

std::vector<std::string> users_code_verdicts(const SceneAudit& a) {
  std::vector<std::string> out;
  for (const VariantAudit& va : a.variants) {
    if (!va.users_code()) continue;
    std::string line = va.label + " (" + va.origin + ")";
    if (!va.stopped.empty()) {
      line += " stopped (" + va.stopped + "): not exact for this scene";
    } else if (va.exact_for_scene()) {
      line += " is exact for this scene: " + markup::format("%.1f", va.ns_per_ray) + " ns per primary ray";
      if (va.tracer)
        line += " (the whole tracer, timed in rayproof's process)";
      else if (va.timed_in_worker)
        line += " (rayproof's traversal plus the code's own time in its worker; " +
                markup::format("%.1f", va.round_trip_ns_per_ray) + " ns with the round trips to the worker)";
      else
        line += " (timed through its pipe: an --exec command cannot be timed where it runs)";
      for (const auto& r : a.recommendation)
        if (r.shape == va.shape && r.best && r.best != &va)
          line += "; the cheapest exact " + std::string(to_string(r.shape)) + " variant is " + r.best->label + " (" +
                  markup::format("%.1f", r.best->ns_per_ray) + " ns)";
    } else {
      line += " is not exact for this scene: " + std::to_string(va.counts.wrong) + " pixels wrong, " +
              std::to_string(va.counts.shadow_wrong) + " shadow wrong";
    }
    out.push_back(std::move(line));
  }
  return out;
}

namespace {

bool has_cases_file(const VariantAudit& va) { return !va.cases.empty() || !va.mesh_cases.empty(); }
std::size_t cases_written(const VariantAudit& va) { return va.cases.size() + va.mesh_cases.size(); }

// STEM-cases.jsonl: each wrong pixel as a case (cases.md; a tracer's as a mesh case, tracer.md),
// "found" saying where it came from.
std::string cases_jsonl(const VariantAudit& va, const std::string& stem, const std::string& scene_path) {
  std::string out;
  for (MeshCase c : va.mesh_cases) {
    c.found["audit"] = scene_path;
    out += json_text(mesh_case_to_json(c)) + "\n";
  }
  for (const WrongPixelCase& w : va.cases) {
    Case c;
    c.ray = w.ray;
    c.shape = w.shape;
    c.id = stem + "-" + std::to_string(w.x) + "-" + std::to_string(w.y) + "-" + w.kind;
    if (w.light >= 0) c.id += "-light" + std::to_string(w.light);
    c.found = {{"audit", scene_path},
               {"variant", va.name},
               {"pixel", {w.x, w.y}},
               {"kind", w.kind},
               {"ray", w.shadow_ray ? "shadow" : "primary"},
               {"primitive", w.primitive}};
    if (w.light >= 0) c.found["light"] = w.light;
    out += json_text(case_to_json(c)) + "\n";
  }
  return out;
}

// HTML text and attributes need the same escapes as SVG's.
std::string fixed(double x, int digits) { return markup::format("%.*f", digits, x); }

// One row of audit.json's "variants" (audit.md), `stem` its files' name.
json variant_row_json(const VariantAudit& va, const std::string& stem) {
  json e = {{"name", va.name},
            {"shape", std::string(to_string(va.shape))},
            {"precision", va.precision},
            {"ns_per_ray", va.ns_per_ray},
            {"wrong", va.counts.wrong},
            {"holes", va.counts.holes},
            {"false_hits", va.counts.false_hits},
            {"shadow_wrong", va.counts.shadow_wrong},
            {"acne", va.counts.acne},
            {"wrongly_shadowed", va.counts.wrongly_shadowed},
            {"wrongly_lit", va.counts.wrongly_lit},
            {"tracer_errors", va.counts.tracer_errors},
            {"exact_for_scene", va.exact_for_scene()},
            {"origin", va.origin},
            {"render", stem + ".png"},
            {"diff", stem + "-diff.png"}};
  if (!va.stopped.empty()) e["stopped"] = va.stopped;
  if (va.proved_offset_ulps) e["proved_offset_ulps"] = *va.proved_offset_ulps;
  if (has_cases_file(va)) {
    e["cases"] = stem + "-cases.jsonl";
    e["cases_written"] = cases_written(va);
    e["cases_left_out"] = va.cases_left_out;
    if (va.tracer) e["pixels_right_as_mesh_cases"] = va.pixels_right_as_mesh_cases;
  }
  if (va.tracer) e["tracer"] = true;  // a whole tracer (tracer.md), drawing every triangle
  if (va.variant && va.variant->external) {
    e["timed_in_worker"] = va.timed_in_worker;
    e["round_trip_ns_per_ray"] = va.round_trip_ns_per_ray;
  }
  return e;
}

// audit.json's headroom part: per row its k's and wrong pixels per k; the scene's own changes.
void add_headroom_json(const SceneAudit& a, json& j) {
  const std::vector<int> ks = headroom_exponents();
  j["headroom"] = json::object();
  for (const VariantAudit& va : a.variants) {
    json h;
    h["exact_up_to_log2_translate"] =
        va.exact_up_to_log2_translate ? json(*va.exact_up_to_log2_translate) : json(nullptr);
    h["first_wrong_log2_translate"] =
        va.first_wrong_log2_translate ? json(*va.first_wrong_log2_translate) : json(nullptr);
    json by_k = json::object();
    for (size_t i = 0; i < ks.size() && i < va.headroom_wrong.size(); ++i)
      if (va.headroom_wrong[i] >= 0) by_k[std::to_string(ks[i])] = va.headroom_wrong[i];
    h["wrong_by_log2_translate"] = by_k;
    j["headroom"][va.label] = h;
  }
  json changed = json::object();
  for (size_t i = 0; i < a.headroom_scene_changed.size(); ++i)
    changed[std::to_string(ks[i])] = a.headroom_scene_changed[i];
  j["headroom_scene_changed_pixels"] = changed;
  if (a.headroom_collapsed_at) j["headroom_scene_collapsed_log2_translate"] = *a.headroom_collapsed_at;
}

json audit_json(const SceneAudit& a, const std::string& scene_path) {
  json j;
  j["scene"] = scene_path;
  j["width"] = a.width;
  j["height"] = a.height;
  j["shapes"] = json::array();
  for (ShapeKind k : a.shapes) j["shapes"].push_back(std::string(to_string(k)));
  j["exact"] = {{"primary_rays", a.primary_rays},
                {"shadow_rays", a.shadow_rays},
                {"seconds", a.exact_seconds},
                {"rays_beyond_intervals", a.rays_beyond_intervals},
                {"fraction_beyond_intervals",
                 a.primary_rays > 0 ? double(a.rays_beyond_intervals) / double(a.primary_rays) : 0.0}};
  j["variants"] = json::array();
  const std::vector<std::string> stems = audit_file_stems(a);
  for (std::size_t i = 0; i < a.variants.size(); ++i)
    j["variants"].push_back(variant_row_json(a.variants[i], stems[i]));
  j["recommendation"] = json::object();
  j["recommendation_within_10_percent"] = json::object();
  for (const auto& r : a.recommendation) {
    j["recommendation"][std::string(to_string(r.shape))] = r.best ? json(r.best->name) : json(nullptr);
    json close = json::array();
    for (const VariantAudit* c : r.close) close.push_back(c->label);
    j["recommendation_within_10_percent"][std::string(to_string(r.shape))] = close;
  }
  if (a.headroom) add_headroom_json(a, j);
  if (!a.warnings.empty()) j["warnings"] = a.warnings;
  return j;
}

// Small renders are shown enlarged by a whole factor (pixelated), so single wrong pixels show.
int enlargement(const Image& img) { return std::max(1, 240 / std::max(1, img.width)); }
std::string img_tag(const Image& img, const std::string& alt) {
  const int factor = enlargement(img);
  return "<img alt=\"" + markup::escape(alt) + "\" width=\"" + std::to_string(img.width * factor) + "\" height=\"" +
         std::to_string(img.height * factor) + "\" src=\"data:image/png;base64," + markup::base64(encode_png(img)) +
         "\">";
}

// A diff image; where it has few marks (one wrong pixel in 76,800 is invisible at 1:1), each is
// circled in its own colour by an SVG laid over the image.
std::string diff_tag(const Image& diff, const std::string& alt) {
  constexpr std::size_t kCircledAtMost = 64;
  std::vector<std::array<int, 2>> marks;
  for (int y = 0; y < diff.height && marks.size() <= kCircledAtMost; ++y)
    for (int x = 0; x < diff.width && marks.size() <= kCircledAtMost; ++x) {
      const auto c = diff.at(x, y);
      if (c == kHoleColour || c == kFalseHitColour || c == kShadowColour || c == kAcneColour) marks.push_back({x, y});
    }
  if (marks.empty() || marks.size() > kCircledAtMost) return img_tag(diff, alt);
  const int factor = enlargement(diff), w = diff.width * factor, h = diff.height * factor;
  std::string out = "<span class=\"circled\">" + img_tag(diff, alt) + "<svg width=\"" + std::to_string(w) +
                    "\" height=\"" + std::to_string(h) + "\" aria-hidden=\"true\">";
  for (const auto& [x, y] : marks) {
    const auto c = diff.at(x, y);
    out += markup::format("<circle cx='%.1f' cy='%.1f' r='%d' fill='none' stroke='rgb(%d,%d,%d)' stroke-width='1.5'/>",
                          (x + 0.5) * factor, (y + 0.5) * factor, std::max(7, 3 * factor), c[0], c[1], c[2]);
  }
  return out + "</svg></span>";
}

// Variants × translation exponent: green where exact, red where some pixel is wrong or shadow
// wrong, light grey where not rendered (an earlier exponent already failed), dark grey from where
// the scene collapsed. The first row is the scene itself: orange where rounding the translated
// coordinates changed its exact render, pale blue where it did not.
std::string headroom_svg(const SceneAudit& a) {
  const std::vector<int> ks = headroom_exponents();
  const double label_w = 190, cell = 22, top = 30;
  const int rows = static_cast<int>(a.variants.size()) + 1;
  const long pixels = static_cast<long>(a.width) * a.height;
  std::ostringstream s;
  const std::vector<std::string> caption = {
      "k: the translation 2^k·(1, 0.75, 0.5), added to the scene's own coordinates",
      "green: no pixel wrong or shadow wrong · red: some · light grey: not rendered (an earlier k failed)",
      "dark grey: the scene collapsed (triangles dropped as degenerate) · top row: pale blue, the scene unchanged;",
      "orange, rounding the translated coordinates changed what the scene itself shows"};
  const double line_h = 15;
  svg::begin(s, label_w + cell * static_cast<double>(ks.size()) + 10,
             top + cell * rows + 16 + line_h * static_cast<double>(caption.size()), 11);
  const auto collapsed = [&](size_t i) { return a.headroom_collapsed_at && ks[i] >= *a.headroom_collapsed_at; };
  constexpr const char* kCollapsedFill = "#8a8a8a";
  const std::string collapsed_title = "the scene collapsed (see the warnings)";
  for (size_t i = 0; i < ks.size(); ++i)
    s << svg::text(label_w + cell * i + cell / 2, top - 8, std::to_string(ks[i]), "text-anchor='middle'");
  auto row = [&](int r, const std::string& label, auto&& cell_of) {
    const double y = top + cell * r;
    s << svg::text(label_w - 6, y + cell * 0.7, label, "text-anchor='end'");
    for (size_t i = 0; i < ks.size(); ++i) {
      const auto [fill, title] = cell_of(i);
      s << svg::rect(label_w + cell * i, y, cell - 2, cell - 2, fill,
                     label + ", k = " + std::to_string(ks[i]) + ": " + title);
    }
    s << "\n";
  };
  row(0, "the scene itself", [&](size_t i) -> std::pair<std::string, std::string> {
    if (collapsed(i)) return {kCollapsedFill, collapsed_title};
    if (i >= a.headroom_scene_changed.size()) return {"#dddddd", "not rendered"};
    const long c = a.headroom_scene_changed[i];
    return {c == 0 ? "#cfe8ff" : (c * 100 < pixels ? "#ffcc80" : "#fb8c00"),
            std::to_string(c) + " pixels see another object than the untranslated scene"};
  });
  for (size_t r = 0; r < a.variants.size(); ++r) {
    const VariantAudit& va = a.variants[r];
    row(static_cast<int>(r) + 1, va.label + " (" + std::string(to_string(va.shape)) + ")",
        [&](size_t i) -> std::pair<std::string, std::string> {
          const long wrong = i < va.headroom_wrong.size() ? va.headroom_wrong[i] : -1;
          if (collapsed(i)) return {kCollapsedFill, collapsed_title};
          if (wrong < 0) return {"#dddddd", "not rendered"};
          return {wrong == 0 ? "#4caf50" : "#e53935", std::to_string(wrong) + " pixels wrong or shadow wrong"};
        });
  }
  for (size_t l = 0; l < caption.size(); ++l)
    s << svg::text(4, top + cell * rows + 16 + line_h * static_cast<double>(l), caption[l]);
  svg::end(s);
  return s.str();
}

// What acne is blocked by, in the scene's own shapes: "the sphere or plane it left", with "or a
// neighbour in its mesh" where the scene has triangles.
std::string acne_words(const std::vector<ShapeKind>& shapes) {
  std::string out = "the ";
  for (size_t i = 0; i < shapes.size(); ++i)
    out += std::string(i == 0 ? "" : i + 1 == shapes.size() ? " or " : ", ") + std::string(to_string(shapes[i]));
  out += " it left";
  if (std::find(shapes.begin(), shapes.end(), ShapeKind::triangle) != shapes.end())
    out += ", or a neighbour in its mesh";
  return out;
}

// The page's head and styles.
void html_head(std::ostream& h, const std::string& scene_path) {
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>rayproof audit: "
    << markup::escape(scene_path) << "</title><style>"
    << "body{font-family:sans-serif;margin:2em;max-width:1400px;color:#222}"
    << "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}"
    << "td:first-child,th:first-child{text-align:left}tr.exact td{background:#eef8ee}"
    << ".pair{display:inline-block;margin:0 1.5em 1.5em 0;vertical-align:top}.pair p.cases{margin:.3em "
       "0;max-width:760px}figure{display:inline-table;margin:0 .5em 0 0}"
    << "figcaption{display:table-caption;caption-side:bottom}"
    << "img{image-rendering:pixelated;border:1px solid #999}.circled{position:relative;display:inline-block}"
    << ".circled svg{position:absolute;left:1px;top:1px;pointer-events:none}.key "
       "span{display:inline-block;width:1em;height:1em;"
    << "margin:0 .3em 0 1em;vertical-align:middle}code{background:#f4f4f4;padding:1px 4px}</style></head><body>\n";
}

// The title, the scene, and the recommendation per shape (with the user's code's verdicts).
void html_recommendation(std::ostream& h, const SceneAudit& a, const std::string& scene_path) {
  h << "<h1>Which intersector does this scene require?</h1>\n<p>Scene <code>" << markup::escape(scene_path)
    << "</code>, " << a.width << "×" << a.height << " pixels, shapes: ";
  for (size_t i = 0; i < a.shapes.size(); ++i) h << (i ? ", " : "") << to_string(a.shapes[i]);
  h << ".</p>\n<h2>Recommendation</h2>\n<ul id=\"recommendation\">";
  // With headroom, each name's k beside its cost: the cheapest exact code may be a float one that
  // stops being exact far sooner than the double ones beside it.
  auto k_of = [&](const VariantAudit& va) {
    if (!a.headroom) return std::string();
    return va.exact_up_to_log2_translate ? ", exact up to k = " + std::to_string(*va.exact_up_to_log2_translate)
                                         : std::string(", no headroom");
  };
  for (const auto& r : a.recommendation) {
    h << "<li><b>" << to_string(r.shape) << "</b>: ";
    if (r.best) {
      h << "<b>" << markup::escape(r.best->name) << "</b>, the cheapest variant that renders this scene exactly ("
        << fixed(r.best->ns_per_ray, 1) << " ns per primary ray" << k_of(*r.best) << ")";
      for (size_t i = 0; i < r.close.size(); ++i)
        h << (i == 0 ? "; within 10%, as good a choice: " : ", ") << markup::escape(r.close[i]->label) << " ("
          << fixed(r.close[i]->ns_per_ray, 1) << " ns" << k_of(*r.close[i]) << ")";
    } else if (r.audited)
      h << "<b>none</b> of the audited variants renders this scene exactly";
    else
      h << "no variant of this shape was audited (see --variants)";
    h << "</li>";
  }
  for (const std::string& v : users_code_verdicts(a))
    h << "<li class=\"yours\">Your code: " << markup::escape(v) << "</li>";
}

// The table of every row, with what each column means.
void html_table(std::ostream& h, const SceneAudit& a) {
  h << "</ul>\n<h2>Every variant on this scene</h2>\n"
    << "<p>Each variant draws its own shape; the other shapes are judged exactly, so each count belongs to that "
       "variant alone. <i>wrong</i>: the visible object differs from the exact one (<i>holes</i>: it sees something "
       "behind or the background; <i>false hits</i>: something in front or where the exact ray meets nothing); "
       "<i>shadow wrong</i>: a light's lit/shadowed status differs, <i>wrongly shadowed</i> (the variant's shadow ray "
       "is blocked, the exact one reaches the light) or <i>wrongly lit</i> (the reverse); <i>acne</i>: wrongly "
       "shadowed by "
    << acne_words(a.shapes) << ". Exact for the scene = 0 wrong and 0 shadow wrong.</p>\n"
    << "<table id=\"variants\"><tr><th>variant</th><th>shape</th><th>precision</th><th>ns/ray</th><th>wrong</th>"
       "<th>holes</th><th>false hits</th><th>shadow wrong</th><th>wrongly shadowed</th><th>wrongly "
       "lit</th><th>acne</th>"
       "<th>exact</th>";
  if (a.headroom) h << "<th>exact up to k</th><th>first wrong k</th>";
  h << "</tr>\n";
  for (const VariantAudit& va : a.variants) {
    const PixelCounts& c = va.counts;
    h << "<tr" << (va.exact_for_scene() ? " class=\"exact\"" : "") << "><td>" << markup::escape(va.label)
      << (va.origin != "built-in" ? " <small>(" + markup::escape(va.origin) + ")</small>" : "")
      << (va.tracer ? " <small>[tracer]</small>" : "") << "</td><td>" << to_string(va.shape) << "</td><td>"
      << va.precision << "</td><td>" << (std::isnan(va.ns_per_ray) ? std::string("–") : fixed(va.ns_per_ray, 1))
      << "</td><td>" << c.wrong << "</td><td>" << c.holes << "</td><td>" << c.false_hits << "</td><td>"
      << c.shadow_wrong << "</td><td>" << c.wrongly_shadowed << "</td><td>" << c.wrongly_lit << "</td><td>" << c.acne
      << "</td><td>" << (va.exact_for_scene() ? "yes" : "no")
      << (va.stopped.empty() ? "" : " (stopped: " + markup::escape(va.stopped) + ")") << "</td>";
    if (a.headroom) {
      auto k = [](const std::optional<int>& x) { return x ? std::to_string(*x) : std::string("–"); };
      h << "<td>" << k(va.exact_up_to_log2_translate) << "</td><td>" << k(va.first_wrong_log2_translate) << "</td>";
    }
    h << "</tr>\n";
  }
  h << "</table>\n<p>Exact render: " << a.primary_rays << " primary and " << a.shadow_rays << " shadow rays in "
    << fixed(a.exact_seconds, 2) << " s; " << a.rays_beyond_intervals << " pixels ("
    << fixed(a.primary_rays ? 100.0 * a.rays_beyond_intervals / a.primary_rays : 0, 3)
    << "%) needed expansions or rationals beyond the double and interval filters.</p>\n";
}

// The headroom chart and what it shows.
void html_headroom(std::ostream& h, const SceneAudit& a) {
  if (a.headroom) {
    h << "<h2>Headroom: how far can this scene move from the origin?</h2>\n<p>The whole scene (camera, lights, "
         "objects) translated by 2<sup>k</sup>·(1, 0.75, 0.5), added to its own coordinates and rounded to doubles, "
         "each variant re-rendered, shadows included: for a variant exact on the scene itself, the largest k before "
         "the first with a pixel wrong or shadow wrong is its headroom.";
    if (a.headroom_collapsed_at)
      h << " <b>From k = " << *a.headroom_collapsed_at
        << " the translated scene collapses</b> (triangles become degenerate and are dropped): nothing beyond is "
           "rendered, and no variant's headroom can reach it.";
    h << "</p>\n<div id=\"headroom\">" << headroom_svg(a) << "</div>\n";
  }
}

// The images: the exact render, then per row the exact, its render and its diff side by side.
void html_images(std::ostream& h, const SceneAudit& a) {
  h << "<h2>Images</h2>\n<p class=\"key\">Diff images, over the dimmed exact render:<span "
       "style=\"background:rgb(255,0,0)\">"
       "</span>hole<span style=\"background:rgb(0,160,255)\"></span>false hit<span style=\"background:rgb(255,255,0)\">"
       "</span>shadow wrong<span style=\"background:rgb(255,128,0)\"></span>acne (shadowed by "
    << acne_words(a.shapes) << "); where a diff has few marks, each is circled.</p>\n";
  // One row per variant: the exact render, the variant's, and the diff, side by side; the
  // variants with something wrong first, the exact ones folded.
  const std::string exact_tag = img_tag(a.exact, "exact render");
  h << "<div class=\"pair\"><figure>" << exact_tag << "<figcaption>the exact render</figcaption></figure></div>\n";
  const std::vector<std::string> stems = audit_file_stems(a);
  auto pair = [&](const VariantAudit& va) {
    const std::string& name = va.label;
    h << "<div class=\"pair\"><figure>" << exact_tag << "<figcaption>exact</figcaption></figure><figure>"
      << img_tag(va.render, name + " render") << "<figcaption>" << markup::escape(name)
      << "</figcaption></figure><figure>" << diff_tag(va.diff, name + " diff") << "<figcaption>" << markup::escape(name)
      << " vs exact: " << va.counts.holes << " holes, " << va.counts.false_hits << " false hits, "
      << va.counts.shadow_wrong << " shadow wrong (" << va.counts.wrongly_shadowed << " wrongly shadowed, "
      << va.counts.wrongly_lit << " wrongly lit)</figcaption></figure>";
    if (has_cases_file(va)) {  // under the three images, as wide as they are
      const std::string file = stems[&va - a.variants.data()] + "-cases.jsonl";
      const std::size_t written = cases_written(va);
      h << "<p class=\"cases\">" << written
        << (va.tracer ? " wrong pixels as mesh cases, shrunk" : " wrong pixels as cases")
        << (va.cases_left_out ? " (of " : "")
        << (va.cases_left_out ? std::to_string(written + va.cases_left_out) + ")" : "") << ": <a href=\""
        << markup::escape(file) << "\">" << markup::escape(file) << "</a>, replayed in this directory by <code>"
        << markup::escape(cases_replay_command(va, file)) << "</code></p>";
    }
    h << "</div>\n";
  };
  long exact_count = 0;
  for (const VariantAudit& va : a.variants)
    if (!va.exact_for_scene())
      pair(va);
    else
      ++exact_count;
  if (exact_count > 0) {
    h << "<details><summary>" << exact_count << " variants render this scene exactly: their images</summary>\n";
    for (const VariantAudit& va : a.variants)
      if (va.exact_for_scene()) pair(va);
    h << "</details>\n";
  }
}

// Warnings, the command that reproduces the page, and the image-count hook for browser tests.
void html_tail(std::ostream& h, const SceneAudit& a, const std::string& scene_path) {
  if (!a.warnings.empty()) {
    h << "<h2>Warnings</h2>\n<ul id=\"warnings\">";
    for (const std::string& w : a.warnings) h << "<li>" << markup::escape(w) << "</li>";
    h << "</ul>\n";
  }
  h << "<p>Reproduce: <code>" << markup::escape(reproduce_command(a, scene_path)) << "</code></p>\n";
  // For automated checks (a headless browser dumps the DOM after load): how many images decoded.
  h << "<script>window.addEventListener('load',function(){var n=0,imgs=document.images;for(var i=0;i<imgs.length;i++)"
       "if(imgs[i].complete&&imgs[i].naturalWidth>0)n++;document.body.setAttribute('data-images-decoded',n+'/"
       "'+imgs.length);});"
       "</script>\n</body></html>\n";
}

}  // namespace

std::string scene_audit_html(const SceneAudit& a, const std::string& scene_path) {
  std::ostringstream h;
  html_head(h, scene_path);
  html_recommendation(h, a, scene_path);
  html_table(h, a);
  if (a.headroom) html_headroom(h, a);
  html_images(h, a);
  html_tail(h, a, scene_path);
  return h.str();
}

void write_scene_audit(const SceneAudit& a, const std::string& scene_path, const std::string& dir) {
  std::filesystem::create_directories(dir);
  write_image(a.exact, dir + "/exact.png");
  const std::vector<std::string> stems = audit_file_stems(a);
  for (std::size_t i = 0; i < a.variants.size(); ++i) {
    write_image(a.variants[i].render, dir + "/" + stems[i] + ".png");
    write_image(a.variants[i].diff, dir + "/" + stems[i] + "-diff.png");
    if (has_cases_file(a.variants[i])) {
      AtomicFile cases(dir + "/" + stems[i] + "-cases.jsonl");
      cases.stream() << cases_jsonl(a.variants[i], stems[i], scene_path);
      cases.commit();
    }
  }
  if (a.headroom) {  // the chart alone too, for pages that embed it
    AtomicFile chart(dir + "/headroom.svg");
    chart.stream() << "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n" << headroom_svg(a);
    chart.commit();
  }
  {
    AtomicFile html(dir + "/report.html");
    html.stream() << scene_audit_html(a, scene_path);
    html.commit();
  }
  AtomicFile out(dir + "/audit.json");
  out.stream() << json_text(audit_json(a, scene_path), 2) << "\n";
  out.commit();
}

}  // namespace rayproof::studies
