#!/usr/bin/env bash
# make demo: one short block per part on screen (under 80 lines), every line of every command in
# out/demo.log; the report to open last.
set -uo pipefail
build=${1:-build}
out=out
mkdir -p "$out"
rp="$build/rayproof"
log="$out/demo.log"
: > "$log"

part() {
  echo
  echo "== $*"
  printf '\n== %s\n' "$*" >> "$log"
}

# show PATTERN COMMAND...: runs COMMAND, appends all it prints to the log and shows the lines
# matching PATTERN; a failing command ends the demo with its last lines.
show() {
  local pattern=$1 text status
  shift
  echo "\$ $*" >> "$log"
  text=$("$@" 2>&1)
  status=$?
  printf '%s\n' "$text" >> "$log"
  if [ $status -ne 0 ]; then
    printf '%s\n' "$text" | tail -20
    echo "rayproof demo: '$*' failed (exit $status); everything it printed is in $log"
    exit 1
  fi
  printf '%s\n' "$text" | grep -E "$pattern" || true
}

part "1/6 render the bundled scenes (the two tutorials' figures, a depth map, every shape)"
for scene in seed1-sphere seed2-diffuse depth all-shapes; do
  show "^$" "$rp" render "scenes/$scene.json" -o "$out/$scene.png"
done
echo "   $out/seed1-sphere.png $out/seed2-diffuse.png $out/depth.png $out/all-shapes.png"

part "2/6 check: every built-in intersector against the exact oracle on the bundled cases (scenes/cases)"
show "^variant |^(textbook|stable|hearn-baker|moller-trumbore|watertight|slab|robust-slab) |^diagnosis|^  (overflow|underflow) of double|^rayproof check:" \
  "$rp" check scenes/cases/*.jsonl -o "$out/check.jsonl" --summary "$out/check-summary.json"

part "3/6 fuzz: a short campaign, every family and shape; findings shrunk, each replayable by check"
show "^family|^tangent(-full)? +textbook |^extremes +hearn-baker |^grazing(-full)? +(moller-trumbore|watertight) |findings in" \
  "$rp" fuzz --count 20000 --max-findings 10 --seed 1 -o "$out/fuzz-findings.jsonl" --summary "$out/fuzz-summary.json"

if [ -f "$build/plugins/weekend_sphere.so" ]; then
  part "4/6 your code: Ray Tracing in One Weekend's sphere as a plugin (examples/plugins), fuzzed"
  show "^family|weekend-sphere +sphere |^  weekend-sphere exit->miss|^    rayproof check .*near-origin/sphere/1/1 |^diagnosis|^  weekend-sphere:|findings in" \
    "$rp" fuzz --plugin "$build/plugins/weekend_sphere.so" --variants weekend-sphere --shapes sphere \
    --families tangent,near-origin --count 20000 -o "$out/plugin-findings.jsonl"
fi

part "5/6 whole tracers (BVH, box test, triangle test, precision) on adversarial meshes, and the one-hit rule"
tracers=bvh-moller-trumbore,bvh-watertight-top-left,cgal-aabb
"$rp" variants | grep -q '^embree-robust' && tracers+=,embree,embree-robust
tracer_lib=()
if [ -f "$build/plugins/naive_float_bvh.so" ]; then
  tracer_lib=(--tracer "$build/plugins/naive_float_bvh.so")
  tracers+=,naive-float-bvh,naive-float-bvh-nan,float-bvh-top-left-1e30
fi
show "one hit per|^    rays\)|findings in" "$rp" fuzz "${tracer_lib[@]}" --tracers "$tracers" \
  --families shared-edges,fans,needles,spawned --count 2048 --max-findings 3 \
  -o "$out/tracer-findings.jsonl" --summary "$out/tracer-summary.json"
show "^$" "$rp" check "$out/tracer-findings.jsonl" "${tracer_lib[@]}" --tracers "$tracers" -o "$out/tracer-check.jsonl"
python3 - "$out/tracer-findings.jsonl" "$out/tracer-check.jsonl" <<'EOF'
import json, sys
found = [json.loads(l) for l in open(sys.argv[1]) if l.strip()]
replayed = {j["id"]: j for j in (json.loads(l) for l in open(sys.argv[2]) if l.strip())}
same = sum(replayed[f["id"]]["tracers"][f["found"]["tracer"]]["kind"] == f["found"]["kind"] for f in found)
sizes = sorted(len(f["mesh"]["triangles"]) for f in found)
print(f"   replayed by check: {same} of {len(found)} findings (shrunk: median mesh {sizes[len(sizes) // 2]} "
      f"triangles) keep the kind they were found with")
EOF

part "6/6 audit: which intersector does a scene need? (docs/spec/audit.md)"
show "^variant|^(moller-trumbore|watertight-top-left|moller-trumbore-f32) |^recommendation" \
  "$rp" audit scenes/audit/edge-grid-tilted.json -o "$out/audit-edge-grid-tilted"
report="$out/audit-edge-grid-tilted/report.html"
if [ -f "$build/scenes/bunny.json" ]; then
  echo "   ... the Stanford bunny moved up to 2^62 from the origin (--headroom), two float codes people copy beside:"
  plugins=()
  for p in glsl_sphere wikipedia_moller_trumbore; do
    [ -f "$build/plugins/$p.so" ] && plugins+=(--plugin "$build/plugins/$p.so")
  done
  show "^variant|^(textbook|stable|direct|moller-trumbore|watertight-top-left|textbook-f32|watertight-f32|glsl-sphere|wikipedia-mt) |^recommendation|^your code" \
    "$rp" audit "$build/scenes/bunny.json" -o "$out/audit-bunny" --headroom "${plugins[@]}"
  report="$out/audit-bunny/report.html"
fi

echo
echo "rayproof demo: every line of every command: $(cd "$out" && pwd)/demo.log; results: $(cd "$out" && pwd)/"
echo "rayproof demo: open the audit report: $(cd "$(dirname "$report")" && pwd)/report.html"
