#!/usr/bin/env python3
"""Instructions per call on random hits, counted by callgrind: per shape the fastest double
variant (the goals' baseline in scripts/bench-goals.py), the oracle's class alone, and class +
correctly rounded t (Oracle::judge), with their ratios to the variant. Where a time ratio misses
its goal (issue 22), this says whether the instructions executed, not the machine, set it.

Usage: scripts/instruction-counts.py BUILD_DIR [--csv OUT]
Needs valgrind (Debian package valgrind); without it, says so and exits 0.
"""
import csv
import os
import re
import shutil
import subprocess
import sys
import tempfile

def _goal_baselines():
    """bench-goals.py's BASELINES: one list of the goals' double variants."""
    import importlib.util
    spec = importlib.util.spec_from_file_location("bench_goals", os.path.join(os.path.dirname(__file__), "bench-goals.py"))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.BASELINES


BASELINES = _goal_baselines()
PASSES = 2  # over the 4096-query ring: 8192 calls a count


def count(binary, routine, shape):
    """Instructions executed inside counted_loop for `routine` over the ring, PASSES times."""
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "callgrind.out")
        run = subprocess.run(
            ["valgrind", "--tool=callgrind", "--toggle-collect=*counted_loop*", f"--callgrind-out-file={out}",
             binary, routine, shape, str(PASSES)],
            capture_output=True, text=True)
        if run.returncode != 0:
            sys.exit(f"instruction-counts: {routine} {shape} failed (exit {run.returncode}):\n{run.stderr[-2000:]}")
        queries = int(re.search(r"(\d+) queries", run.stdout).group(1))
        with open(out) as f:
            totals = [line for line in f if line.startswith(("totals:", "summary:"))]
        if not totals:
            sys.exit(f"instruction-counts: no totals in callgrind's output for {routine} {shape}")
        return int(totals[-1].split()[1]), queries * PASSES


def main(argv):
    if len(argv) < 2 or ("--csv" in argv and argv.index("--csv") + 1 >= len(argv)):
        sys.exit(__doc__)
    binary = os.path.join(argv[1], "bench", "rayproof_instructions")
    if not shutil.which("valgrind"):
        print("instruction counts: valgrind not installed (apt-get install valgrind); skipped")
        return 0
    if not os.path.exists(binary):
        sys.exit(f"instruction-counts: {binary} not built")
    rows = []
    print("Instructions per call, random hits (callgrind; the loop's own subtracted):")
    print(f"  {'shape':9} {'variant':16} {'variant':>8} {'class':>8} {'ratio':>6} {'class+t':>8} {'ratio':>6}")
    for shape, variant in BASELINES:
        loop, calls = count(binary, "none", shape)
        per = {r: (count(binary, r, shape)[0] - loop) / calls for r in (variant, "class", "judge")}
        rows.append({"shape": shape, "variant": variant, "variant_instructions": round(per[variant], 1),
                     "class_instructions": round(per["class"], 1), "judge_instructions": round(per["judge"], 1)})
        print(f"  {shape:9} {variant:16} {per[variant]:8.1f} {per['class']:8.1f} {per['class'] / per[variant]:5.2f}x"
              f" {per['judge']:8.1f} {per['judge'] / per[variant]:5.2f}x")
    if "--csv" in argv:
        path = argv[argv.index("--csv") + 1]  # (checked before counting: see main's start)
        tmp = path + ".tmp"
        with open(tmp, "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
        os.replace(tmp, path)
        print(f"instruction counts: {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
