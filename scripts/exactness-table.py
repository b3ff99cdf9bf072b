#!/usr/bin/env python3
"""docs/results/oracle-costs.md's table, built from one `make bench` run (build/bench.json).

Per shape and family: the fastest scalar double variant (the certified ones aside), the oracle's
class alone, class + correctly rounded t (filtered), the same forced through rationals, and the
certified variant, in ns per query, with the ratios issue 11 asks for (class <= 2x, class + t
<= 8x the fastest double variant on random rays; <= 2 us on every adversarial family).
Usage: scripts/exactness-table.py build/bench.json
"""
import json
import sys

FAMILIES = ["random-hit", "random-miss", "tangent", "grazing", "near-origin", "extremes"]
SHAPES = ["sphere", "plane", "triangle", "box"]
VARIANTS = {"sphere": ["textbook", "stable", "stable-fma", "hearn-baker"], "plane": ["direct"],
            "triangle": ["moller-trumbore", "watertight"], "box": ["slab", "robust-slab"]}


def main(path):
    ns = {}
    for r in json.load(open(path))["benchmarks"]:
        ns[r["name"]] = r.get("per_test", r["real_time"] * 1e-9) * 1e9
    print("| shape | family | fastest double variant | oracle class | oracle class + t | forced rational "
          "| certified variant | class / double | class + t / double |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|")
    for shape in SHAPES:
        for family in FAMILIES:
            timed = [(ns[f"variant/{v}/{family}"], v) for v in VARIANTS[shape] if f"variant/{v}/{family}" in ns]
            if not timed:
                continue
            fastest, name = min(timed)
            cls = ns.get(f"oracle/{shape}/{family}/class")
            full = ns.get(f"oracle/{shape}/{family}/filtered")
            exact = ns.get(f"oracle/{shape}/{family}/exact")
            certified = ns.get(f"variant/certified-{shape}/{family}")
            fmt = lambda x: "-" if x is None else f"{x:.1f}"
            ratio = lambda x: "-" if x is None else f"{x / fastest:.1f}x"
            print(f"| {shape} | {family} | {name} {fastest:.1f} | {fmt(cls)} | {fmt(full)} | {fmt(exact)} "
                  f"| {fmt(certified)} | {ratio(cls)} | {ratio(full)} |")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "build/bench.json")
