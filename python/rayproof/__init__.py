"""rayproof from Python: the exact oracle, fuzzing campaigns and whole tracers judged in-process.

    import rayproof
    rayproof.judge({"ray": {...}, "shape": {...}})            # a case (docs/spec/cases.md)
    rayproof.judge_many("sphere", origins, directions, spheres)  # NumPy arrays, in parallel
    report = rayproof.fuzz_tracer(MyTracer(), families=["shared-edges"], count=640)
    rayproof.check(MyTracer(), report["findings"])              # replay what was found

A tracer is any object with build(vertices, triangles) returning a scene (often the tracer
itself) whose nearest(origins, directions, tmin, tmax) returns (triangles, t) for a batch of rays
as NumPy arrays; a triangle < 0 or NO_TRIANGLE is no hit. Optionally all_hits(...) returns one
list of triangles per ray, and the tracer may declare `name`, `precision` ("double" or "float")
and `range` ("open" or "closed"). The judging runs in C++ (GIL released) as the CLI's does;
findings are dicts in the mesh-case format, so `rayproof check` replays them (through
`python3 -m rayproof.serve`) and rayproof.check replays the CLI's.
"""
import json
import os
import shutil
import tempfile

from . import _rayproof

__all__ = ["judge", "judge_many", "variants", "fuzz", "fuzz_tracer", "check", "read_cases", "write_cases",
           "failing_outcomes", "CLASSES", "NO_TRIANGLE", "FAMILIES", "TRACER_FAMILIES"]

CLASSES = _rayproof.CLASSES  # judge_many's class codes index this tuple
NO_TRIANGLE = _rayproof.NO_TRIANGLE
FAMILIES = ("random", "tangent", "grazing", "near-origin", "exit-entry", "extremes")
TRACER_FAMILIES = ("shared-edges", "fans", "axis-planes", "needles", "spawned", "shells", "far", "random")
LEVELLED_KINDS = ("hole", "false_hit", "not_nearest", "double_hit", "missed_in_any_hit")
DEFAULT_TOLERANCE_ULPS = 16.0  # K of docs/spec/verdicts.md


def _names(value, default, what):
    if value is None:
        return list(default)
    if isinstance(value, str):
        value = [v for v in value.split(",") if v]
    value = list(value)
    if not value:
        raise ValueError(f"{what}: an empty list")
    return value


def _threads(threads):
    return (os.cpu_count() or 1) if threads is None else int(threads)


def judge(case, answer=None, *, precision="double", rule="nearest", range="open",
          tolerance=DEFAULT_TOLERANCE_ULPS):
    """The exact verdict on one case: {"class", "t"} (t correctly rounded, a hex-float string).

    With answer={"class": ..., "t": ...}, also what `rayproof check` says of that answer under
    "answer": agrees, ulp, and for a disagreement or a t not correctly rounded its level, backward
    error beta (ulps) and the witness the oracle checked (docs/spec/verdicts.md).
    """
    return _rayproof.judge(case, answer, precision, rule, range, float(tolerance))


def judge_many(shape, origins, directions, shapes, classes=None, t=None, *, rule="nearest", precision="double",
               range="open", tolerance=DEFAULT_TOLERANCE_ULPS, threads=None):
    """The exact class (codes into CLASSES) and t (NaN where none) of n rays against n shapes.

    origins, directions: (n, 3); shapes: (n, k) in the case format's order — sphere: centre,
    radius; plane: normal, offset; triangle: three vertices; box: min, max. With your code's
    answers — classes (codes into CLASSES, or their names) and t (NaN where none) — also per row
    "agrees" (2 agrees, 1 cannot tell, 0 wrong, -1 not representable in float), "ulp" (-1: no t),
    "beta" (backward error in ulps; NaN: right, inf: none, -inf: unproved) and "level" (0 right,
    1 rounding, 2 bug), as `rayproof check` judges them.
    """
    if classes is not None:
        import numpy as np
        classes = np.asarray(classes)
        if classes.dtype.kind in "UO":
            codes = {name: i for i, name in enumerate(CLASSES)}
            unknown = sorted({str(c) for c in classes.ravel()} - set(codes))
            if unknown:
                raise ValueError(f"classes: unknown class {unknown[0]!r} (one of {', '.join(CLASSES)})")
            classes = np.vectorize(codes.get, otypes=[np.int64])(classes) if classes.size else classes.astype(np.int64)
        if t is None:
            t = np.full(classes.shape, np.nan)
    return _rayproof.judge_many(shape, origins, directions, shapes, classes, t, rule, precision, range,
                                float(tolerance), _threads(threads))


def variants():
    """Every built-in variant and tracer: dicts of name, shape ("mesh" for tracers), precision, source."""
    return _rayproof.variants()


def read_cases(path):
    """The lines of a case or findings file as dicts (blank lines skipped)."""
    with open(path, encoding="utf-8") as f:
        return [json.loads(line) for line in f if line.strip()]


def write_cases(path, cases):
    """Cases (dicts) as a JSON Lines file `rayproof check` reads, written atomically."""
    tmp = f"{path}.tmp{os.getpid()}"
    with open(tmp, "w", encoding="utf-8") as f:
        for c in cases:
            f.write(json.dumps(c) + "\n")
    os.replace(tmp, path)


def _with_findings(run, output):
    """Runs run(path) with a findings path (a temporary one unless given) and adds the findings."""
    where = tempfile.mkdtemp(prefix="rayproof-") if output is None else None
    path = os.path.join(where, "findings.jsonl") if where else os.fspath(output)
    try:
        report = run(path)
        report["findings"] = read_cases(path) if os.path.exists(path) else []
        report["output"] = None if where else path
        return report
    finally:
        if where:
            shutil.rmtree(where, ignore_errors=True)


def fuzz(variants=None, families=None, shapes=None, count=1000, seed=1, *, threads=None, output=None,
         rule="nearest", tolerance=DEFAULT_TOLERANCE_ULPS, shrink=True, max_findings=1000):
    """A campaign over built-in variants, as `rayproof fuzz`: {"tallies", "findings", "table", ...}.

    Tallies are keyed "FAMILY\\tVARIANT"; findings are case dicts `rayproof check` replays.
    """
    return _with_findings(
        lambda path: _rayproof.fuzz(_names(variants, [], "variants") if variants is not None else [],
                                    _names(families, FAMILIES, "families"),
                                    _names(shapes, ("sphere", "plane", "triangle", "box"), "shapes"), int(count),
                                    int(seed), _threads(threads), path, rule, float(tolerance), bool(shrink),
                                    int(max_findings)), output)


def _declared(tracer, name, precision, range):
    return (name or getattr(tracer, "name", None) or "python",
            precision or getattr(tracer, "precision", None) or "double",
            range or getattr(tracer, "range", None) or "open")


def fuzz_tracer(tracer, families=None, count=640, seed=1, *, name=None, precision=None, range=None, threads=1,
                output=None, tolerance=DEFAULT_TOLERANCE_ULPS, shrink=True, max_findings=20):
    """Your tracer on the tracer families, judged by the exact oracle as `rayproof fuzz --tracer`.

    count is rays per family (64 per mesh). Returns {"tallies" (keyed "FAMILY\\tNAME", any-hit
    mode "FAMILY-any\\tNAME"), "findings" (mesh cases, bugs first, shrunk), "table",
    "one_hit_rule", "diagnosis", "output"}. A tracer that raises is a `crash` finding with its
    traceback in found.reason (the tracer is then stopped); a malformed answer is a tracer error.
    threads > 1 judges in parallel; the tracer is called under the GIL, one scene at a time when
    build returns the tracer itself.
    """
    name, precision, range = _declared(tracer, name, precision, range)
    return _with_findings(
        lambda path: _rayproof.fuzz_tracer(tracer, _names(families, TRACER_FAMILIES, "families"), int(count), int(seed),
                                           _threads(threads), path, name, precision, range, float(tolerance),
                                           bool(shrink), int(max_findings)), output)


def check(tracer, cases, *, name=None, precision=None, range=None, tolerance=DEFAULT_TOLERANCE_ULPS):
    """Mesh cases (a findings file's path, a list of dicts or one dict) replayed on your tracer:
    one `rayproof check` line per case, {"id", "expect", "tracers": {NAME: {... "kind"}}}."""
    if isinstance(cases, (str, os.PathLike)):
        cases = read_cases(cases)
    elif isinstance(cases, dict):
        cases = [cases]
    name, precision, range = _declared(tracer, name, precision, range)
    return _rayproof.check_tracer(tracer, list(cases), name, precision, range, float(tolerance))


def failing_outcomes(report, level="bug"):
    """How many of a tracer report's outcomes fail, as `--fail-on` counts them: tracer errors,
    crashes, timeouts, and the disagreements of `level` ("bug": bug-level only; "rounding": all)."""
    failing = 0
    for tally in report["tallies"].values():
        failing += sum(tally.get(k, 0) for k in ("tracer_errors", "crash", "timeout"))
        for k in LEVELLED_KINDS:
            failing += tally.get(k, 0) if level == "rounding" else tally.get(k + "_bugs", 0)
    return failing
