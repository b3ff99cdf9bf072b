"""pytest helpers, the Python twin of the GoogleTest matchers (rayproof/fuzz/testing.h):

    from rayproof.testing import assert_no_bugs
    def test_my_tracer():
        assert_no_bugs(MyTracer(), families=["shared-edges", "fans"], count=640)

A failure shows the verdict table, the first finding of each failing kind shrunk (a mesh case of
a few triangles) and two ways to replay the findings: rayproof.check in Python, and the CLI's
`rayproof check` through `python3 -m rayproof.serve`.
"""
import inspect
import json
import os
import tempfile

import rayproof


def _serve_command(tracer):
    """How the CLI runs this tracer: python3 -m rayproof.serve FILE:NAME (None when its class has no file)."""
    cls = type(tracer)
    try:
        path = inspect.getsourcefile(cls)
    except TypeError:
        return None
    if not path or "<" in cls.__qualname__:
        return None
    return f"python3 -m rayproof.serve {os.path.abspath(path)}:{cls.__qualname__}"


def assert_no_bugs(tracer, families=None, count=640, seed=1, *, level="bug", findings=None, **options):
    """Fails (AssertionError) when the exact oracle finds a failing outcome: a tracer error, crash,
    or a disagreement of `level` ("bug": bug-level only, docs/spec/verdicts.md; "rounding": any).
    Findings go to `findings` (default: a file in the temporary directory, named in the message).
    Other options are rayproof.fuzz_tracer's. Returns the report when nothing fails."""
    if level not in ("bug", "rounding"):
        raise ValueError(f"level must be 'bug' or 'rounding', got {level!r}")
    if findings is None:
        name = options.get("name") or getattr(tracer, "name", None) or "python"
        findings = os.path.join(tempfile.gettempdir(), f"rayproof-{name}-{os.getpid()}.jsonl")
    report = rayproof.fuzz_tracer(tracer, families, count, seed, output=findings, **options)
    failing = rayproof.failing_outcomes(report, level)
    if failing == 0:
        return report
    shown, lines = set(), []
    for f in report["findings"]:
        found = f.get("found", {})
        kind = found.get("kind")
        if kind in shown or (level == "bug" and found.get("level") == "rounding"):
            continue
        shown.add(kind)
        triangles = len(f["mesh"]["triangles"])
        reason = f" ({found['reason'].splitlines()[-1]})" if found.get("reason") else ""
        lines.append(f"  {kind} in family {found.get('family')}, shrunk to {triangles} triangle"
                     f"{'s' if triangles != 1 else ''}{reason}:\n    {json.dumps(f)}")
    name = next(iter(report["tallies"])).split("\t")[1] if report["tallies"] else "python"
    replay = [f"  Python: rayproof.check(tracer, {findings!r})"]
    serve = _serve_command(tracer)
    if serve:
        replay.append(f"  CLI:    rayproof check {findings} --tracer-exec {name}='{serve}'")
    message = (f"rayproof: {failing} failing outcomes ({level} level) of tracer {name}\n{report['table']}"
               + "\n".join(report.get("diagnosis", [])) + "\nfirst finding of each kind:\n" + "\n".join(lines)
               + f"\nall findings: {findings}\nreplay:\n" + "\n".join(replay))
    raise AssertionError(message)
