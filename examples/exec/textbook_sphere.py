#!/usr/bin/env python3
"""A sphere intersector in Python, judged by rayproof over the exec protocol (docs/spec/plugin.md).

The textbook quadratic (-b ± sqrt(b^2 - 4ac)) / 2a in Python floats (IEEE doubles), answering
"hit at t" like most scripts do. Every other shape is answered as a miss.
Run: rayproof check scenes/cases/sphere.jsonl --exec py-sphere=examples/exec/textbook_sphere.py
"""
import json
import math
import sys


def number(x):
    return float.fromhex(x) if isinstance(x, str) else float(x)


def answer(case):
    shape = case["shape"]
    if shape["type"] != "sphere":
        return {"id": case["id"], "class": "miss"}
    o = [number(x) for x in case["ray"]["origin"]]
    d = [number(x) for x in case["ray"]["direction"]]
    m = [number(x) for x in shape["center"]]
    r = number(shape["radius"])
    oc = [o[i] - m[i] for i in range(3)]
    a = sum(x * x for x in d)
    b = 2 * sum(d[i] * oc[i] for i in range(3))
    c = sum(x * x for x in oc) - r * r
    disc = b * b - 4 * a * c
    if disc >= 0 and math.isfinite(disc):
        root = math.sqrt(disc)
        for t in ((-b - root) / (2 * a), (-b + root) / (2 * a)):
            if t > 0 and math.isfinite(t):
                return {"id": case["id"], "class": "hit", "t": t.hex()}
    return {"id": case["id"], "class": "miss"}


for line in sys.stdin:  # one answer per case, flushed, so rayproof can keep many cases in flight
    print(json.dumps(answer(json.loads(line))), flush=True)
