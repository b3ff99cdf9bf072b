#!/usr/bin/env bash
# make demo: render the bundled scenes and audit the bundled cases; say where results are.
set -euo pipefail
build=${1:-build}
out=out
mkdir -p "$out"
rp="$build/rayproof"
for scene in seed1-sphere seed2-diffuse depth all-shapes; do
  "$rp" render "scenes/$scene.json" -o "$out/$scene.png"
done
if "$rp" check --help > /dev/null 2>&1 && [ -d scenes/cases ]; then
  echo "rayproof check on the bundled audit suite (scenes/cases):"
  "$rp" check scenes/cases/*.jsonl -o "$out/check.jsonl" --summary "$out/check-summary.json"
fi
echo "rayproof fuzz: a short campaign, every family and shape (shrunk findings, replayable by check):"
"$rp" fuzz --count 20000 --max-findings 10 --seed 1 -o "$out/fuzz-findings.jsonl" --summary "$out/fuzz-summary.json" \
  2>&1 | grep -E "^(family|tangent(-full)? +textbook|grazing(-full)? +(moller-trumbore|watertight)|extremes +(textbook|hearn-baker))|^t error|findings in" || true
if [ -f "$build/plugins/weekend_sphere.so" ]; then
  echo "your own code: the Ray Tracing in One Weekend sphere as a plugin (examples/plugins), fuzzed on tangents"
  echo "and rays spawned from surfaces: one case per kind with the command that replays it, then the diagnosis:"
  "$rp" fuzz --plugin "$build/plugins/weekend_sphere.so" --variants weekend-sphere --shapes sphere \
    --families tangent,near-origin --count 20000 -o "$out/plugin-findings.jsonl" 2>&1 \
    | grep -E "^(family|(tangent|near-origin)(-full)? +weekend)|^examples|^  weekend-sphere|^    rayproof check|^diagnosis|findings in" || true
fi
echo "rayproof fuzz --tracer: whole tracers (BVH, box test, triangle test, precision together) on adversarial"
echo "meshes, with the one-hit-per-shared-edge rule GPU APIs promise (docs/spec/tracer.md):"
tracers=bvh-moller-trumbore,bvh-watertight-top-left,cgal-aabb
"$rp" variants | grep -q '^embree-robust' && tracers+=,embree,embree-robust
tracer_lib=()
if [ -f "$build/plugins/naive_float_bvh.so" ]; then
  tracer_lib=(--tracer "$build/plugins/naive_float_bvh.so")
  tracers+=,naive-float-bvh,naive-float-bvh-nan,float-bvh-top-left-1e30
fi
"$rp" fuzz "${tracer_lib[@]}" --tracers "$tracers" --families shared-edges,fans,needles,spawned --count 2048 \
  --max-findings 3 -o "$out/tracer-findings.jsonl" --summary "$out/tracer-summary.json" 2>&1 \
  | grep -E "one hit per|findings in" || true
echo "... each finding shrunk to a few triangles and replayed by check (its kind again):"
"$rp" check "$out/tracer-findings.jsonl" "${tracer_lib[@]}" --tracers "$tracers" -o "$out/tracer-check.jsonl" 2>&1 \
  | grep -E "^tracer|rayproof check" || true
echo "rayproof audit: which intersector does a scene need? (docs/spec/audit.md)"
"$rp" audit scenes/audit/edge-grid-tilted.json -o "$out/audit-edge-grid-tilted" 2>&1 \
  | grep -E "^(variant|moller|watertight|recommendation|wrong pixels of)" || true
if [ -f "$build/scenes/bunny.json" ]; then
  echo "... the Stanford bunny on a ground plane with a ball and a light, moved up to 2^62 from the origin"
  echo "    (--headroom), with two float intersectors people copy (examples/plugins) beside the built-ins:"
  plugins=()
  for p in glsl_sphere wikipedia_moller_trumbore; do
    [ -f "$build/plugins/$p.so" ] && plugins+=(--plugin "$build/plugins/$p.so")
  done
  "$rp" audit "$build/scenes/bunny.json" -o "$out/audit-bunny" --headroom "${plugins[@]}" 2>&1 \
    | grep -E "^(variant|textbook|stable|hearn|direct|moller|watertight|glsl|wikipedia|certified|recommendation|your code|rayproof audit: warning)" || true
  report="$out/audit-bunny/report.html"
else
  report="$out/audit-edge-grid-tilted/report.html"
fi
echo
echo "rayproof demo: results are in $(cd "$out" && pwd)/"
echo "rayproof demo: open the audit report: $(cd "$(dirname "$report")" && pwd)/report.html"
ls -1 "$out" | sed 's/^/  /'
