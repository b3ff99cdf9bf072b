#!/usr/bin/env python3
"""docs/results/fuzz.md's tables from a campaign summary (rayproof fuzz --summary FILE).

Percent of cases wrong / cannot tell per variant and family (in parentheses: the percent of cases
whose disagreement is bug-level, verdicts.md; holes on grazing triangles), then
cases checked per second per core per shape and family.
Usage: scripts/fuzz-table.py SUMMARY.json [THREADS]
"""
import json
import sys

FAMILIES = ["random", "tangent", "grazing", "near-origin", "exit-entry", "extremes"]
VARIANTS = ["textbook", "stable", "stable-fma", "hearn-baker", "certified-sphere", "direct", "certified-plane",
            "moller-trumbore", "watertight", "certified-triangle", "slab", "robust-slab", "certified-box"]
SHAPES = ["sphere", "plane", "triangle", "box"]


FULL = ["tangent-full", "grazing-full", "exit-entry-full", "extremes-full"]  # random, near-origin: one construction


def main(path, threads):
    s = json.load(open(path))
    tallies = s["tallies"]
    rates(tallies, FAMILIES)
    if any(k.split("\t")[0].endswith("-full") for k in tallies):
        print()
        print("Full-precision construction (`--construction full`):")
        print()
        rates(tallies, FULL)
    throughput(s, threads, FAMILIES + [f for f in FULL if any(k.startswith(f + "\t") for k in s["cases"])])


def rates(tallies, families):
    for line in rate_rows(tallies, families):
        print(line)


def rate_rows(tallies, families):
    """The rate table's lines: a header, a rule and one row per variant (scripts/readme-numbers.py
    compares README's rows with these)."""
    rows = ["| variant | " + " | ".join(families) + " |", "|---|" + "---|" * len(families)]
    for v in VARIANTS:
        cells = []
        for f in families:
            t = tallies.get(f"{f}\t{v}")
            if not t:
                cells.append("-")
                continue
            cell = f"{100 * t['wrong'] / t['cases']:.3f} / {100 * t['cannot_tell'] / t['cases']:.3f}"
            if "bugs" in t:  # verdicts.md: the bug-level share of both, in percent of cases
                cell += f" ({100 * t['bugs'] / t['cases']:.3f})"
            if f.startswith("grazing") and v in ("moller-trumbore", "watertight", "certified-triangle"):
                cell += f" · {t['shared_edge_holes']} holes"
            cells.append(cell)
        rows.append(f"| `{v}` | " + " | ".join(cells) + " |")
    return rows


def throughput(s, threads, families):
    print()
    print("| cases/s per core | " + " | ".join(families) + " |")
    print("|---|" + "---|" * len(families))
    for shape in SHAPES:
        cells = []
        for f in families:
            key = f"{f}\t{shape}"
            seconds, cases = s["seconds"].get(key), s["cases"].get(key)
            cells.append("-" if not seconds else f"{cases / seconds / threads / 1000:.0f}k")
        print(f"| {shape} | " + " | ".join(cells) + " |")


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 2)
