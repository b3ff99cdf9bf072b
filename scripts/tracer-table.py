#!/usr/bin/env python3
"""docs/results/tracers.md's tables from a tracer campaign summary (rayproof fuzz --tracer... --summary FILE).

Per family and tracer, nearest mode then any-hit mode, the bug-level disagreements as
"hole/false/not-nearest" and "hole/false/double/missed" per 100,000 rays judged, the
rounding-level ones beside them as "(r ...)" with ties and range-end notes; then each
tracer's one-hit-rule line and ns per ray per family. With FINDINGS, one shrunk finding per
tracer (the smallest) as a one-line JSON.
Usage: scripts/tracer-table.py SUMMARY.json [FINDINGS.jsonl]
"""
import json
import sys

FAMILIES = ["shared-edges", "fans", "axis-planes", "needles", "spawned", "shells", "far", "random"]


def main(path, findings=None):
    s = json.load(open(path))
    t = s["tallies"]
    tracers = sorted({k.split("\t")[1] for k in t})
    print("| family | " + " | ".join(f"`{x}`" for x in tracers) + " |")
    print("|---|" + "---|" * len(tracers))
    for fam in FAMILIES:
        for mode, kinds in (("", ["hole", "false_hit", "not_nearest"]), ("-any", ["hole", "false_hit", "double_hit", "missed_in_any_hit"])):
            cells = []
            for x in tracers:
                r = t.get(f"{fam}{mode}\t{x}")
                if not r:
                    cells.append("-")
                    continue
                judged = r["cases"] - r.get("not_representable", 0) - r.get("unsupported", 0)
                if judged <= 0:
                    cells.append("n/a")
                    continue
                # Bugs first; rounding-level disagreements beside them (verdicts.md §4), where
                # the summary has levels.
                if "tolerance_ulps" in r:
                    parts = [f"{r.get(k + '_bugs', 0)}" for k in kinds]
                    rounding = [f"{r.get(k + '_rounding', 0)}" for k in kinds if k != "double_hit"]
                    notes = []
                    if r.get("ties"):
                        notes.append(f"{r['ties']} ties")
                    if r.get("at_range_end"):
                        notes.append(f"{r['at_range_end']} at range end")
                    extra = " (r " + "/".join(rounding) + (", " + ", ".join(notes) if notes else "") + ")"
                else:
                    parts = [f"{r.get(k, 0)}" for k in kinds]
                    extra = ""
                if r.get("tracer_errors"):
                    extra += f" +{r['tracer_errors']} err"
                if r.get("not_representable"):
                    extra += f" ({r['not_representable']} n/r)"
                cells.append("/".join(parts) + extra)
            print(f"| {fam}{' any-hit' if mode else ''} | " + " | ".join(cells) + " |")
    print()
    for x in tracers:
        print(f"- `{x}`: {s['one_hit_rule'][x]}")
        for line in s.get("diagnosis", {}).get(x, []):
            print(f"  - diagnosis: {line}")
    print()
    print("| ns per ray (nearest) | " + " | ".join(f"`{x}`" for x in tracers) + " |")
    print("|---|" + "---:|" * len(tracers))
    for fam in FAMILIES:
        keys = [fam + "\t" + x for x in tracers]
        print(f"| {fam} | " + " | ".join(f"{t[k]['ns_per_ray']:.0f}" if k in t else "-" for k in keys) + " |")
    secs = sum(s["seconds"].values())
    rays = sum(s["rays"].values())
    print()
    print(f"{rays} rays per tracer, {len(tracers)} tracers, {secs:.0f} s in all ({secs / 60:.1f} min)")
    if findings:
        best = {}
        for line in open(findings):
            f = json.loads(line)
            x = f["found"]["tracer"]
            n = len(f["mesh"]["triangles"])
            if x not in best or n < len(best[x]["mesh"]["triangles"]):
                best[x] = f
        print()
        for x, f in sorted(best.items()):
            print(f"{x}: {json.dumps(f)}")


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2] if len(sys.argv) > 2 else None)
