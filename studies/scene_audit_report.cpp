// The audit's files: audit.json (docs/spec/audit.md's keys, plus compatible extras), the PNGs
// and report.html, one self-contained page.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "rayproof/core/atomic_file.h"
#include "rayproof/core/json_fields.h"
#include "rayproof/studies/scene_audit.h"
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
std::vector<std::string> image_stems(const SceneAudit& a) {
  std::set<std::string> taken = {"exact.png", "report.html", "audit.json", "headroom.svg"};
  std::vector<std::string> stems;
  for (const VariantAudit& va : a.variants) {
    const std::string base = file_stem(va.label);
    std::string stem = base;
    for (int k = 2; taken.count(stem + ".png") || taken.count(stem + "-diff.png"); ++k) stem = base + "-" + std::to_string(k);
    taken.insert(stem + ".png");
    taken.insert(stem + "-diff.png");
    stems.push_back(stem);
  }
  return stems;
}

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
      if (exec) once(loads, "--tracer-exec " + shell_quoted(va.name + "=" + va.origin.substr(6)));
      else if (library) once(loads, "--tracer " + shell_quoted(va.origin));
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

std::string base64(const std::string& bytes) {
  static constexpr char kAlphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  for (size_t i = 0; i < bytes.size(); i += 3) {
    const unsigned a = static_cast<unsigned char>(bytes[i]);
    const unsigned b = i + 1 < bytes.size() ? static_cast<unsigned char>(bytes[i + 1]) : 0;
    const unsigned c = i + 2 < bytes.size() ? static_cast<unsigned char>(bytes[i + 2]) : 0;
    const unsigned n = a << 16 | b << 8 | c;
    out += kAlphabet[n >> 18 & 63];
    out += kAlphabet[n >> 12 & 63];
    out += i + 1 < bytes.size() ? kAlphabet[n >> 6 & 63] : '=';
    out += i + 2 < bytes.size() ? kAlphabet[n & 63] : '=';
  }
  return out;
}

// HTML text and attributes need the same escapes as SVG's.
std::string html_escape(std::string_view s) { return svg::escape(s); }
std::string fixed(double x, int digits) { return svg::format("%.*f", digits, x); }

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
  const std::vector<std::string> stems = image_stems(a);
  for (std::size_t i = 0; i < a.variants.size(); ++i) {
    const VariantAudit& va = a.variants[i];
    json e = {{"name", va.name},
              {"shape", std::string(to_string(va.shape))},
              {"precision", va.precision},
              {"ns_per_ray", va.ns_per_ray},
              {"wrong", va.counts.wrong},
              {"holes", va.counts.holes},
              {"false_hits", va.counts.false_hits},
              {"shadow_wrong", va.counts.shadow_wrong},
              {"acne", va.counts.acne},
              {"exact_for_scene", va.exact_for_scene()},
              {"origin", va.origin},
              {"render", stems[i] + ".png"},
              {"diff", stems[i] + "-diff.png"}};
    if (!va.stopped.empty()) e["stopped"] = va.stopped;
    if (va.tracer) e["tracer"] = true;  // a whole tracer (tracer.md), drawing every triangle
    j["variants"].push_back(std::move(e));
  }
  j["recommendation"] = json::object();
  j["recommendation_within_10_percent"] = json::object();
  for (const auto& r : a.recommendation) {
    j["recommendation"][std::string(to_string(r.shape))] = r.best ? json(r.best->name) : json(nullptr);
    json close = json::array();
    for (const VariantAudit* c : r.close) close.push_back(c->label);
    j["recommendation_within_10_percent"][std::string(to_string(r.shape))] = close;
  }
  if (a.headroom) {
    j["headroom"] = json::object();
    for (const VariantAudit& va : a.variants) {
      json h;
      h["exact_up_to_log2_translate"] = va.exact_up_to_log2_translate ? json(*va.exact_up_to_log2_translate) : json(nullptr);
      h["first_wrong_log2_translate"] = va.first_wrong_log2_translate ? json(*va.first_wrong_log2_translate) : json(nullptr);
      json by_k = json::object();
      const std::vector<int> ks = headroom_exponents();
      for (size_t i = 0; i < ks.size() && i < va.headroom_wrong.size(); ++i)
        if (va.headroom_wrong[i] >= 0) by_k[std::to_string(ks[i])] = va.headroom_wrong[i];
      h["wrong_by_log2_translate"] = by_k;
      j["headroom"][va.label] = h;
    }
  }
  if (a.headroom) {
    json changed = json::object();
    const std::vector<int> ks = headroom_exponents();
    for (size_t i = 0; i < a.headroom_scene_changed.size(); ++i) changed[std::to_string(ks[i])] = a.headroom_scene_changed[i];
    j["headroom_scene_changed_pixels"] = changed;
  }
  if (!a.warnings.empty()) j["warnings"] = a.warnings;
  return j;
}

// Small renders are shown enlarged by a whole factor (pixelated), so single wrong pixels show.
std::string img_tag(const Image& img, const std::string& alt) {
  const int factor = std::max(1, 240 / std::max(1, img.width));
  return "<img alt=\"" + html_escape(alt) + "\" width=\"" + std::to_string(img.width * factor) + "\" height=\"" +
         std::to_string(img.height * factor) + "\" src=\"data:image/png;base64," + base64(encode_png(img)) + "\">";
}

// Variants × translation exponent: green where exact, red where some pixel is wrong, grey where
// not rendered (an earlier exponent already failed). The first row is the scene itself: orange
// where rounding the translated coordinates changed its exact render, pale blue where it did not.
std::string headroom_svg(const SceneAudit& a) {
  const std::vector<int> ks = headroom_exponents();
  const double label_w = 190, cell = 22, top = 30;
  const int rows = static_cast<int>(a.variants.size()) + 1;
  const long pixels = static_cast<long>(a.width) * a.height;
  std::ostringstream s;
  svg::begin(s, label_w + cell * static_cast<double>(ks.size()) + 10, top + cell * rows + 40, 11);
  for (size_t i = 0; i < ks.size(); ++i)
    s << svg::text(label_w + cell * i + cell / 2, top - 8, std::to_string(ks[i]), "text-anchor='middle'");
  auto row = [&](int r, const std::string& label, auto&& cell_of) {
    const double y = top + cell * r;
    s << svg::text(label_w - 6, y + cell * 0.7, label, "text-anchor='end'");
    for (size_t i = 0; i < ks.size(); ++i) {
      const auto [fill, title] = cell_of(i);
      s << svg::rect(label_w + cell * i, y, cell - 2, cell - 2, fill, label + ", k = " + std::to_string(ks[i]) + ": " + title);
    }
    s << "\n";
  };
  row(0, "the scene itself", [&](size_t i) -> std::pair<std::string, std::string> {
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
          if (wrong < 0) return {"#dddddd", "not rendered"};
          return {wrong == 0 ? "#4caf50" : "#e53935", std::to_string(wrong) + " wrong pixels"};
        });
  }
  s << svg::text(4, top + cell * rows + 30,
                 "translation 2^k·(1, 0.75, 0.5), k →  green: 0 wrong pixels · red: some wrong · grey: not rendered · "
                 "top row: pale blue, the scene unchanged; orange, rounding changed the scene itself");
  svg::end(s);
  return s.str();
}

}  // namespace

std::string scene_audit_html(const SceneAudit& a, const std::string& scene_path) {
  std::ostringstream h;
  h << "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\"><title>rayproof audit: "
    << html_escape(scene_path) << "</title><style>"
    << "body{font-family:sans-serif;margin:2em;max-width:1400px;color:#222}"
    << "table{border-collapse:collapse;margin:1em 0}td,th{border:1px solid #ccc;padding:3px 8px;text-align:right}"
    << "td:first-child,th:first-child{text-align:left}tr.exact td{background:#eef8ee}"
    << ".pair{display:inline-block;margin:0 1.5em 1.5em 0;vertical-align:top}figure{display:inline-block;margin:0 .5em 0 0}"
    << "img{image-rendering:pixelated;border:1px solid #999}.key span{display:inline-block;width:1em;height:1em;"
    << "margin:0 .3em 0 1em;vertical-align:middle}code{background:#f4f4f4;padding:1px 4px}</style></head><body>\n";
  h << "<h1>Which intersector does this scene require?</h1>\n<p>Scene <code>" << html_escape(scene_path) << "</code>, "
    << a.width << "×" << a.height << " pixels, shapes: ";
  for (size_t i = 0; i < a.shapes.size(); ++i) h << (i ? ", " : "") << to_string(a.shapes[i]);
  h << ".</p>\n<h2>Recommendation</h2>\n<ul id=\"recommendation\">";
  for (const auto& r : a.recommendation) {
    h << "<li><b>" << to_string(r.shape) << "</b>: ";
    if (r.best)
    {
      h << "<b>" << html_escape(r.best->name) << "</b>, the cheapest variant that renders this scene exactly ("
        << fixed(r.best->ns_per_ray, 1) << " ns per primary ray)";
      for (size_t i = 0; i < r.close.size(); ++i)
        h << (i == 0 ? "; within 10%, as good a choice: " : ", ") << html_escape(r.close[i]->label) << " ("
          << fixed(r.close[i]->ns_per_ray, 1) << " ns)";
    }
    else if (r.audited)
      h << "<b>none</b> of the audited variants renders this scene exactly";
    else
      h << "no variant of this shape was audited (see --variants)";
    h << "</li>";
  }
  h << "</ul>\n<h2>Every variant on this scene</h2>\n"
    << "<p>Each variant draws its own shape; the other shapes are judged exactly, so each count belongs to that "
       "variant alone. <i>wrong</i>: the visible object differs from the exact one (<i>holes</i>: it sees something "
       "behind or the background; <i>false hits</i>: something in front or where the exact ray meets nothing); "
       "<i>shadow wrong</i>: a light's lit/shadowed status differs (<i>acne</i>: blocked by the triangle it left or a "
       "neighbour). Exact for the scene = 0 wrong and 0 shadow wrong.</p>\n"
    << "<table id=\"variants\"><tr><th>variant</th><th>shape</th><th>precision</th><th>ns/ray</th><th>wrong</th>"
       "<th>holes</th><th>false hits</th><th>shadow wrong</th><th>acne</th><th>exact</th>";
  if (a.headroom) h << "<th>exact up to k</th><th>first wrong k</th>";
  h << "</tr>\n";
  for (const VariantAudit& va : a.variants) {
    const PixelCounts& c = va.counts;
    h << "<tr" << (va.exact_for_scene() ? " class=\"exact\"" : "") << "><td>" << html_escape(va.label)
      << (va.origin != "built-in" ? " <small>(" + html_escape(va.origin) + ")</small>" : "")
      << (va.tracer ? " <small>[tracer]</small>" : "")
      << "</td><td>" << to_string(va.shape) << "</td><td>" << va.precision << "</td><td>"
      << fixed(va.ns_per_ray, 1) << "</td><td>" << c.wrong << "</td><td>" << c.holes << "</td><td>" << c.false_hits
      << "</td><td>" << c.shadow_wrong << "</td><td>" << c.acne << "</td><td>"
      << (va.exact_for_scene() ? "yes" : "no") << (va.stopped.empty() ? "" : " (stopped: " + html_escape(va.stopped) + ")")
      << "</td>";
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
  if (a.headroom) {
    h << "<h2>Headroom: how far can this scene move from the origin?</h2>\n<p>The whole scene (camera, lights, "
         "objects) translated by 2<sup>k</sup>·(1, 0.75, 0.5), coordinates rounded to doubles, each variant "
         "re-rendered: the largest k with 0 wrong pixels is its headroom.</p>\n<div id=\"headroom\">"
      << headroom_svg(a) << "</div>\n";
  }
  h << "<h2>Images</h2>\n<p class=\"key\">Diff images, over the dimmed exact render:<span style=\"background:rgb(255,0,0)\">"
       "</span>hole<span style=\"background:rgb(0,160,255)\"></span>false hit<span style=\"background:rgb(255,255,0)\">"
       "</span>shadow wrong<span style=\"background:rgb(255,128,0)\"></span>acne</p>\n";
  // One row per variant: the exact render, the variant's, and the diff, side by side; the
  // variants with something wrong first, the exact ones folded.
  const std::string exact_tag = img_tag(a.exact, "exact render");
  h << "<div class=\"pair\"><figure>" << exact_tag << "<figcaption>the exact render</figcaption></figure></div>\n";
  auto pair = [&](const VariantAudit& va) {
    const std::string& name = va.label;
    h << "<div class=\"pair\"><figure>" << exact_tag << "<figcaption>exact</figcaption></figure><figure>"
      << img_tag(va.render, name + " render") << "<figcaption>" << html_escape(name)
      << "</figcaption></figure><figure>" << img_tag(va.diff, name + " diff") << "<figcaption>" << html_escape(name)
      << " vs exact: " << va.counts.holes << " holes, " << va.counts.false_hits << " false hits, " << va.counts.shadow_wrong
      << " shadow wrong</figcaption></figure></div>\n";
  };
  long exact_count = 0;
  for (const VariantAudit& va : a.variants)
    if (!va.exact_for_scene()) pair(va);
    else ++exact_count;
  if (exact_count > 0) {
    h << "<details><summary>" << exact_count << " variants render this scene exactly: their images</summary>\n";
    for (const VariantAudit& va : a.variants)
      if (va.exact_for_scene()) pair(va);
    h << "</details>\n";
  }
  h << "<p>Reproduce: <code>" << html_escape(reproduce_command(a, scene_path)) << "</code></p>\n";
  // For automated checks (a headless browser dumps the DOM after load): how many images decoded.
  h << "<script>window.addEventListener('load',function(){var n=0,imgs=document.images;for(var i=0;i<imgs.length;i++)"
       "if(imgs[i].complete&&imgs[i].naturalWidth>0)n++;document.body.setAttribute('data-images-decoded',n+'/'+imgs.length);});"
       "</script>\n</body></html>\n";
  return h.str();
}

void write_scene_audit(const SceneAudit& a, const std::string& scene_path, const std::string& dir) {
  std::filesystem::create_directories(dir);
  write_image(a.exact, dir + "/exact.png");
  const std::vector<std::string> stems = image_stems(a);
  for (std::size_t i = 0; i < a.variants.size(); ++i) {
    write_image(a.variants[i].render, dir + "/" + stems[i] + ".png");
    write_image(a.variants[i].diff, dir + "/" + stems[i] + "-diff.png");
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
