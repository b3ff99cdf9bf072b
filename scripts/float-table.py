#!/usr/bin/env python3
"""docs/results/float-or-double.md's table from a campaign summary (rayproof fuzz --summary FILE).

Per shape and family, each formula's disagreement rate in double beside its float twin's
(NAME-f32, judged on the case rounded to float), and the cases float could not hold.
Usage: scripts/float-table.py SUMMARY.json
"""
import json
import sys

PAIRS = {"sphere": ["textbook", "stable", "stable-fma", "hearn-baker"], "plane": ["direct"],
         "triangle": ["moller-trumbore", "watertight", "watertight-top-left"], "box": ["slab", "robust-slab"]}
FAMILIES = ["random", "tangent", "tangent-full", "grazing", "grazing-full", "near-origin", "exit-entry",
            "exit-entry-full", "extremes", "extremes-full"]


def rate(t):
    return (t["wrong"] + t["cannot_tell"]) / t["cases"] * 100 if t["cases"] else 0.0


def main(path):
    t = json.load(open(path))["tallies"]
    print("| shape | formula | " + " | ".join(FAMILIES) + " |")
    print("|---|---|" + "---:|" * len(FAMILIES))
    for shape, names in PAIRS.items():
        for n in names:
            cells = []
            for f in FAMILIES:
                d, s = t.get(f"{f}\t{n}"), t.get(f"{f}\t{n}-f32")
                if not d or not s:
                    cells.append("-")
                    continue
                nr = s.get("not_representable", 0)
                cells.append(f"{rate(d):.1f} / {rate(s):.1f}" + (f" ({nr} n/r)" if nr else ""))
            print(f"| {shape} | `{n}` | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "build/fuzz-summary.json")
