"""A Python tracer over the exec-tracer protocol (docs/spec/tracer.md), for the CLI:

    rayproof check findings.jsonl --tracer-exec mine='python3 -m rayproof.serve my_tracer.py:MyTracer'

TRACER is FILE.py:NAME or MODULE:NAME, NAME a class or function called with no arguments that
returns the tracer (an object with build and nearest, as rayproof.fuzz_tracer takes). One ray per
line, each passed to nearest (or all_hits) as a batch of one: what the module saves is this
round trip. The rays of a mesh whose build returned None are answered {"error": "bad mesh"}; an
exception ends the process, which rayproof reports as the tracer's crash.
"""
import importlib
import importlib.util
import json
import os
import sys

import numpy as np


def load(spec):
    """The tracer TRACER names (FILE.py:NAME or MODULE:NAME), made."""
    where, _, attr = spec.rpartition(":")
    if not where or not attr:
        raise SystemExit(f"rayproof.serve: expected FILE.py:NAME or MODULE:NAME, got {spec!r}")
    if where.endswith(".py"):
        module_spec = importlib.util.spec_from_file_location(os.path.splitext(os.path.basename(where))[0], where)
        if module_spec is None:
            raise SystemExit(f"rayproof.serve: cannot load {where}")
        module = importlib.util.module_from_spec(module_spec)
        sys.path.insert(0, os.path.dirname(os.path.abspath(where)))
        module_spec.loader.exec_module(module)
    else:
        module = importlib.import_module(where)
    return getattr(module, attr)()


def number(x):
    if isinstance(x, str):
        return float(x) if x in ("inf", "-inf") else float.fromhex(x)
    return float(x)


def serve(tracer, lines=sys.stdin, out=sys.stdout):
    scene = None
    for line in lines:
        msg = json.loads(line)
        if "mesh" in msg:
            vertices = np.array([[number(x) for x in v] for v in msg["mesh"]["vertices"]], dtype=np.float64)
            triangles = np.array(msg["mesh"]["triangles"], dtype=np.uint32).reshape(-1, 3)
            scene = tracer.build(vertices, triangles)
            continue
        if scene is None:  # each ray of a mesh the tracer declined: as a build() returning NULL
            print(json.dumps({"error": "bad mesh"}), file=out, flush=True)
            continue
        rays = [np.array([[number(x) for x in msg[k]]]) for k in ("origin", "direction")]
        rays += [np.array([number(msg[k])]) for k in ("tmin", "tmax")]
        if msg.get("all"):
            if not hasattr(scene, "all_hits"):
                answer = {"id": msg["id"], "error": "unsupported"}
            else:
                answer = {"id": msg["id"], "triangles": [int(i) for i in scene.all_hits(*rays)[0]]}
        else:
            triangles, t = scene.nearest(*rays)
            i = int(np.asarray(triangles)[0])
            hit = 0 <= i < 0xFFFFFFFF
            answer = {"id": msg["id"], "triangle": i if hit else None}
            if hit:
                answer["t"] = float(np.asarray(t, dtype=np.float64)[0]).hex()
        print(json.dumps(answer), file=out, flush=True)


if __name__ == "__main__":
    if len(sys.argv) != 2:
        raise SystemExit("usage: python3 -m rayproof.serve FILE.py:NAME|MODULE:NAME")
    serve(load(sys.argv[1]))
