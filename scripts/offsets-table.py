#!/usr/bin/env python3
"""docs/results/offsets.md's table: `rayproof offsets` on the bundled bunny
scene scaled by 2^k, k = -30 ... 30 in steps of 10, for Möller–Trumbore and the watertight test in
double and float.
Prints the Markdown rows (k values with identical rows merged); the brackets need more rays per
triangle (report.html and offsets.json give them: `rayproof offsets ... --count 10000000`).
Usage: scripts/offsets-table.py BUILD_DIR [--count N]   (about two minutes on 2 cores)
"""
import json
import pathlib
import subprocess
import sys
import tempfile

build = pathlib.Path(sys.argv[1])
count = sys.argv[sys.argv.index("--count") + 1] if "--count" in sys.argv else "100000"
variants = "moller-trumbore,moller-trumbore-f32,watertight,watertight-f32"
rows = {}
with tempfile.TemporaryDirectory() as tmp:
    for k in range(-30, 31, 10):
        out = pathlib.Path(tmp) / f"k{k}"
        subprocess.run([str(build / "rayproof"), "offsets", str(build / "scenes" / "bunny.json"), "-o", str(out),
                        "--variants", variants, "--count", count, "--log2-scale", str(k), "--threads", "2"],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        report = json.loads((out / "offsets.json").read_text())
        for v in report["variants"]:
            ulps = sorted(p["required_ulps"] for p in v["primitives"] if p["required_ulps"] is not None)
            cells = []
            for r in v["rules"]:
                if r["verdict"] == "unsafe":
                    cells.append(f"**unsafe** ({r['unsafe']:,})")
                elif r["verdict"] == "safe":
                    cells.append("safe")
                else:
                    cells.append(f"unproved ({r['safe']:,} safe)")
            row = (v["name"], " | ".join(cells), f"{ulps[len(ulps) // 2]:,.0f} / {ulps[-1]:,.0f}")
            rows.setdefault(row, []).append(k)

print("| k | variant | fixed:1e-4 | ulps:32 | pbrt | waechter-binder | proved | needs (ulps, median / max) |")
print("|---|---|---|---|---|---|---|---|")
def ks(values):
    return ", ".join(str(k).replace("-", "−") for k in values) if len(values) < 3 else \
        f"{str(values[0]).replace('-', '−')} … {str(values[-1]).replace('-', '−')}"
for (name, cells, needs), k in sorted(rows.items(), key=lambda item: (item[1][0], item[0][0])):
    print(f"| {ks(k)} | `{name}` | {cells} | {needs} |")
