#!/usr/bin/env python3
"""What rayproof finds in the code people copy: each example of examples/ fuzzed on every family,
its disagreement rates and one shrunk failing case, as docs/results/copied-code.md shows.

Usage: scripts/copied-code.py [BUILD_DIR] [COUNT]   (default build, 20000 cases per family)
Each row is reproducible with the command printed beside it. One thread: where the crash budget
(--max-crashes) stops an example, how many cases it answered first depends on how threads
interleave; everything else is the same for any thread count.
"""
import json
import os
import subprocess
import sys
import tempfile

EXAMPLES = [  # (variant, shape, how it is loaded)
    ("weekend-sphere", "sphere", "--plugin {b}/plugins/weekend_sphere.so"),
    ("scratchapixel-sphere", "sphere", "--plugin {b}/plugins/scratchapixel_sphere.so"),
    ("glsl-sphere", "sphere", "--plugin {b}/plugins/glsl_sphere.so"),
    ("wikipedia-mt", "triangle", "--plugin {b}/plugins/wikipedia_moller_trumbore.so"),
    ("minmax-slab", "box", "--plugin {b}/plugins/minmax_slab_box.so"),
    ("py-sphere", "sphere", "--exec py-sphere=examples/exec/textbook_sphere.py"),
]
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
FAMILIES = ["random", "tangent", "grazing", "near-origin", "exit-entry", "extremes"]


def markdown(build, count, shown="build"):
    """docs/results/copied-code.md's block: the table, a blank line, one bullet per example
    (scripts/readme-numbers.py --full compares the page's with it line by line). The commands
    run in BUILD and are printed with `shown` in its place (the docs say `build/`, whatever
    folder this build is in)."""
    rows, cases = [], []
    with tempfile.TemporaryDirectory() as tmp:
        for name, shape, load in EXAMPLES:
            out = os.path.join(tmp, name + ".jsonl")
            command = (f"{shown}/rayproof fuzz {load.format(b=shown)} --variants {name} --shapes {shape} "
                       f"--count {count} --seed 1 --threads 1 -o {name}.jsonl --summary {name}.json")
            run = (f"{build}/rayproof fuzz {load.format(b=build)} --variants {name} --shapes {shape} "
                   f"--count {count} --seed 1 --threads 1 -o {out} --summary {out}.json")
            # From the repository's root, where README's reproduce lines are run (examples/exec/...).
            subprocess.run(run, shell=True, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                           cwd=ROOT)
            tallies = json.load(open(out + ".json"))["tallies"]
            cells = []
            for family in FAMILIES:
                # An --exec command's tallies go by NAME@SHAPE (the shapes it answers), a plugin's by NAME.
                t = tallies.get(f"{family}\t{name}", tallies.get(f"{family}\t{name}@{shape}"))
                if t is None:
                    cells.append("-")
                    continue
                failures = [f"{t[k]} {k.replace('_', ' ')}" for k in ("crashes", "timeouts", "protocol_errors", "plugin_errors") if t.get(k)]
                if t["cases"] == 0:
                    cells.append("stopped: " + ", ".join(failures) if failures else "-")
                    continue
                rate = 100.0 * (t["wrong"] + t["cannot_tell"]) / t["cases"]
                cell = f"{rate:.2f}% ({100.0 * t['wrong'] / t['cases']:.2f}% wrong)"
                if failures:
                    cell += "; " + ", ".join(failures)
                answered = t["cases"] + sum(t.get(k, 0) for k in ("not_representable", "crashes", "timeouts",
                                                                    "protocol_errors", "plugin_errors"))
                if answered < count:  # the crash budget (--max-crashes) stopped the variant
                    cell += f", stopped after {answered} cases"
                cells.append(cell)
            rows.append(f"| `{name}` | {shape} | " + " | ".join(cells) + " |")
            # One shrunk failing case: the first finding with a wrong class (else the first at all).
            findings = [json.loads(l) for l in open(out) if l.strip()]
            pick = next((f for f in findings if f["found"].get("kind") is None and
                         f["found"]["disagreeing"].get(name, {}).get("class") not in (None, "miss") or
                         f["found"].get("kind")), findings[0] if findings else None)
            if pick:
                found = pick["found"]
                answer = found["disagreeing"].get(name, {})
                what = answer.get("error") or f"answers {answer.get('class')}" + (f" at t = {answer['t']}" if answer.get("t") else "")
                case = {k: pick[k] for k in ("id", "ray", "shape", "expect")}
                cases.append(f"- `{name}` ({found['family']}, {'shrunk' if 'shrunk_for' in found else 'as found'}): "
                             f"exact `{pick['expect']['class']}`, {what}:\n  `{json.dumps(case)}`\n  "
                             f"reproduce: `{command}`")
    return "\n".join(["| example | shape | " + " | ".join(FAMILIES) + " |", "|---|---|" + "---|" * len(FAMILIES)] + rows +
                     [""] + cases)


def main(build, count):
    print(markdown(build, count))


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "build", int(sys.argv[2]) if len(sys.argv) > 2 else 20000)
