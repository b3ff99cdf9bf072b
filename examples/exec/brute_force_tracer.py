#!/usr/bin/env python3
"""A whole tracer in Python over the exec-tracer protocol (docs/spec/tracer.md): no acceleration
structure, every triangle tested with Möller–Trumbore in Python floats (IEEE doubles), inclusive
edges, any-hit mode too. What a first prototype looks like; rayproof judges it like any tracer.
Run: rayproof fuzz --tracer-exec py-brute=examples/exec/brute_force_tracer.py --tracers py-brute \
       --families shared-edges --count 640 -o py.jsonl
"""
import json
import sys


def number(x):
    if x == "inf":
        return float("inf")
    return float.fromhex(x) if isinstance(x, str) else float(x)


def sub(a, b):
    return [a[0] - b[0], a[1] - b[1], a[2] - b[2]]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def hit(o, d, v0, v1, v2):
    e1, e2 = sub(v1, v0), sub(v2, v0)
    p = cross(d, e2)
    det = dot(e1, p)
    if det == 0:
        return None
    s = sub(o, v0)
    u = dot(s, p) / det
    if u < 0 or u > 1:
        return None
    q = cross(s, e1)
    v = dot(d, q) / det
    if v < 0 or u + v > 1:
        return None
    return dot(e2, q) / det


vertices, triangles = [], []
for line in sys.stdin:
    msg = json.loads(line)
    if "mesh" in msg:
        vertices = [[number(x) for x in v] for v in msg["mesh"]["vertices"]]
        triangles = msg["mesh"]["triangles"]
        continue
    o, d = [number(x) for x in msg["origin"]], [number(x) for x in msg["direction"]]
    tmin, tmax = number(msg["tmin"]), number(msg["tmax"])
    found = []
    for i, (a, b, c) in enumerate(triangles):
        t = hit(o, d, vertices[a], vertices[b], vertices[c])
        if t is not None and tmin < t < tmax:
            found.append((t, i))
    if msg.get("all"):
        answer = {"id": msg["id"], "triangles": [i for _, i in found]}
    elif found:
        t, i = min(found)
        answer = {"id": msg["id"], "triangle": i, "t": t.hex()}
    else:
        answer = {"id": msg["id"], "triangle": None}
    print(json.dumps(answer), flush=True)
