#!/usr/bin/env python3
"""The same NumPy tracer (examples/python/numpy_tracer.py) judged two ways in one run (issue 43):
in-process through the module (rayproof.fuzz_tracer, 64 rays a call) and through the
exec-tracer protocol (`rayproof fuzz --tracer-exec ... python3 -m rayproof.serve`, one ray a
line). Same families, count, seed, one thread, no shrinking; prints wall time per ray of each
whole campaign, the tracer's own time per ray (the tallies' ns_per_ray) and their ratios, and
the module's overhead per batch (a tracer that returns a constant answer).
Usage: PYTHONPATH=BUILD/python python3 scripts/python-speed.py BUILD [--count N] [--json OUT]
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(SOURCE, "examples", "python"))
import rayproof  # noqa: E402
from numpy_tracer import NumpyTracer  # noqa: E402

FAMILIES = ["fans", "needles", "axis-planes", "far", "shells", "spawned", "shared-edges", "random"]


class Constant:
    """Answers every ray 'no hit' without looking: what is left is the module's own cost."""
    name = "constant"

    def build(self, vertices, triangles):
        return self

    def nearest(self, origins, directions, tmin, tmax):
        n = len(origins)
        return np.full(n, -1, dtype=np.int64), np.full(n, np.nan)


def tracer_us(report, family=None):
    """Time inside the tracer's calls per ray (both modes), as the tallies measure it."""
    tallies = [t for k, t in report["tallies"].items() if family is None or k.split("\t")[0] in (family, family + "-any")]
    return sum(t["seconds"] for t in tallies) * 1e6 / sum(t["timed_rays"] for t in tallies)


def campaign_us(report, family):
    """The family's whole campaign (generating, tracing, judging) per ray."""
    return report["seconds"][family] * 1e6 / report["rays"][family]


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("build")
    p.add_argument("--count", type=int, default=640, help="rays per family (default 640)")
    p.add_argument("--json", help="write the figures here too")
    a = p.parse_args()
    families = ",".join(FAMILIES)
    start = time.perf_counter()
    module = rayproof.fuzz_tracer(NumpyTracer(), FAMILIES, a.count, shrink=False)
    module_wall = time.perf_counter() - start
    with tempfile.TemporaryDirectory() as tmp:
        summary = os.path.join(tmp, "summary.json")
        command = f"{sys.executable} -m rayproof.serve {os.path.join(SOURCE, 'examples/python/numpy_tracer.py')}:NumpyTracer"
        start = time.perf_counter()
        subprocess.run([os.path.join(a.build, "rayproof"), "fuzz", "--tracer-exec", f"numpy-mt={command}",
                        "--families", families, "--count", str(a.count), "--threads", "1", "--no-shrink",
                        "-o", os.path.join(tmp, "f.jsonl"), "--summary", summary],
                       check=True, capture_output=True, env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
        exec_wall = time.perf_counter() - start
        with open(summary, encoding="utf-8") as f:
            exec_report = json.load(f)
    for key, tally in module["tallies"].items():  # the same verdicts either way
        other = exec_report["tallies"][key]
        for k in ("right", "hole", "false_hit", "not_nearest", "double_hit", "missed_in_any_hit", "tracer_errors"):
            assert tally[k] == other[k], (key, k, tally[k], other[k])
    constant = rayproof.fuzz_tracer(Constant(), FAMILIES, a.count, shrink=False)
    batches = sum(t["timed_rays"] for t in constant["tallies"].values()) / 64  # 64 rays a mesh, one call
    overhead_us = sum(t["seconds"] for t in constant["tallies"].values()) * 1e6 / batches
    rows = []
    print(f"NumPy Möller–Trumbore tracer (numpy {np.__version__}), {a.count} rays per family in both modes, "
          "one thread, no shrinking")
    print(f"{'family':14} {'tracer us/ray: module':>22} {'exec':>8} {'ratio':>6}   "
          f"{'campaign us/ray: module':>24} {'exec':>8} {'ratio':>6}")
    for family in FAMILIES:
        row = {"family": family, "module_tracer_us": tracer_us(module, family),
               "exec_tracer_us": tracer_us(exec_report, family), "module_campaign_us": campaign_us(module, family),
               "exec_campaign_us": campaign_us(exec_report, family)}
        row["tracer_ratio"] = row["exec_tracer_us"] / row["module_tracer_us"]
        row["campaign_ratio"] = row["exec_campaign_us"] / row["module_campaign_us"]
        rows.append(row)
        print(f"{family:14} {row['module_tracer_us']:22.1f} {row['exec_tracer_us']:8.1f} {row['tracer_ratio']:5.1f}x   "
              f"{row['module_campaign_us']:24.1f} {row['exec_campaign_us']:8.1f} {row['campaign_ratio']:5.1f}x")
    total = {"module_tracer_us": tracer_us(module), "exec_tracer_us": tracer_us(exec_report),
             "module_wall_s": module_wall, "exec_wall_s": exec_wall}
    print(f"{'all':14} {total['module_tracer_us']:22.1f} {total['exec_tracer_us']:8.1f} "
          f"{total['exec_tracer_us'] / total['module_tracer_us']:5.1f}x   "
          f"{'wall ' + format(module_wall, '.2f') + ' s':>24} {format(exec_wall, '.2f') + ' s':>8} "
          f"{exec_wall / module_wall:5.1f}x")
    print(f"the module's own overhead: {overhead_us:.1f} us per call of 64 rays (a tracer answering a constant)")
    if a.json:
        with open(a.json, "w", encoding="utf-8") as f:
            json.dump({"numpy": np.__version__, "count": a.count, "families": rows, "total": total,
                       "module_overhead_us_per_batch": overhead_us}, f, indent=2)


if __name__ == "__main__":
    main()
