#!/usr/bin/env bash
# The outputs a refactoring must leave byte for byte as they were: `check` on the bundled suite,
# a fixed-seed campaign (findings and summary), renders of the bundled scenes, an audit (its
# JSON without the timings) and stability maps of every shape (CSV and SVG). Writes them under OUT with one SHA-256 per file in OUT/SHA256SUMS;
# compare two builds with `diff A/SHA256SUMS B/SHA256SUMS`.
# Usage: scripts/same-outputs.sh RAYPROOF_BINARY OUT
set -euo pipefail
bin=$(realpath "$1"); out=$2
cd "$(dirname "$0")/.."
mkdir -p "$out"
"$bin" check scenes/cases/*.jsonl -o "$out/check.jsonl" --summary "$out/check-summary.json" 2> /dev/null
"$bin" fuzz --count 3000 --seed 7 --threads 2 -o "$out/fuzz.jsonl" --summary "$out/fuzz-summary.json" 2> /dev/null
for scene in scenes/seed1-sphere.json scenes/seed2-diffuse.json scenes/all-shapes.json scenes/depth.json; do
  "$bin" render "$scene" -o "$out/$(basename "$scene" .json).png" > /dev/null 2>&1
done
"$bin" audit scenes/audit/edge-grid-tilted.json -o "$out/audit" > /dev/null 2>&1
"$bin" stability --shapes all --from -100 --to 100 --step 50 --count 50 -o "$out/stability" > /dev/null 2>&1
# Timings differ run to run: drop every key that holds one (and the audit's recommendation, which
# picks the cheapest exact variant by its timing).
python3 - "$out" <<'PY'
import json, pathlib, sys
out = pathlib.Path(sys.argv[1])
def strip(x):
    if isinstance(x, dict):
        return {k: strip(v) for k, v in x.items() if not any(w in k for w in ("seconds", "ns_per", "_ns", "time", "recommendation"))}
    if isinstance(x, list):
        return [strip(v) for v in x]
    return x
for path in [out / "fuzz-summary.json", out / "check-summary.json", *sorted((out / "audit").glob("*.json"))]:
    path.write_text(json.dumps(strip(json.load(open(path))), sort_keys=True, indent=1))
PY
# The audit's report and plots hold timings; the stability heatmaps do not.
(cd "$out" && find . -type f ! -name SHA256SUMS ! -name '*.html' \( ! -name '*.svg' -o -path './stability/*' \) | sort |
  xargs sha256sum > SHA256SUMS)
wc -l < "$out/SHA256SUMS"
