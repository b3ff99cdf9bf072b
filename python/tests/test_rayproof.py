"""The Python module against the CLI and the exact oracle (issue 43). Run by ctest (python_module)
with PYTHONPATH=BUILD/python, RAYPROOF_BIN=BUILD/rayproof and RAYPROOF_SOURCE=the source tree."""
import json
import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import rayproof
from rayproof.testing import assert_no_bugs

SOURCE = os.environ.get("RAYPROOF_SOURCE", os.path.join(os.path.dirname(__file__), "..", ".."))
BIN = os.environ.get("RAYPROOF_BIN", "rayproof")
sys.path.insert(0, os.path.join(SOURCE, "examples", "python"))
from numpy_tracer import NumpyTracer  # noqa: E402

NUMPY_TRACER = os.path.join(SOURCE, "examples", "python", "numpy_tracer.py")


def cli(*args, check=True):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    r = subprocess.run([BIN, *args], capture_output=True, text=True, env=env)
    if check:
        assert r.returncode == 0, r.stderr
    return r


def kinds(lines, name):
    return [line["tracers"][name]["kind"] for line in lines]


# ---------------------------------------------------------------- the oracle
def test_judge_agrees_with_the_bundled_expectations():
    cases = rayproof.read_cases(os.path.join(SOURCE, "scenes", "cases", "triangle.jsonl"))[:200]
    for c in cases:
        v = rayproof.judge(c)
        assert v["class"] == c["expect"]["class"], c["id"]
        if "t" in c["expect"]:
            assert float.fromhex(v["t"]) == float.fromhex(c["expect"]["t"]) if isinstance(c["expect"]["t"], str) \
                else float(c["expect"]["t"]), c["id"]


SPHERE = {"ray": {"origin": [0, 0, -5], "direction": [0, 0, 1]},
          "shape": {"type": "sphere", "center": [0, 0, 0], "radius": 1}}


def test_judge_an_answer_gives_its_backward_error_and_witness():
    right = rayproof.judge(SPHERE, {"class": "enter", "t": 4.0})["answer"]
    assert right["agrees"] and right.get("ulp") == 0 and "beta_t" not in right
    off = rayproof.judge(SPHERE, {"class": "enter", "t": np.nextafter(4.0, 5.0)})["answer"]
    assert off["ulp"] == 1 and off["level_t"] == "rounding" and off["witness_t"]["ulps"] <= 16
    wrong = rayproof.judge(SPHERE, {"class": "miss"})["answer"]
    assert not wrong["agrees"] and wrong["level"] == "bug" and wrong["range"] == "open"


def test_judge_refuses_bad_cases_naming_the_field():
    with pytest.raises(ValueError, match="radius"):
        rayproof.judge({**SPHERE, "shape": {"type": "sphere", "center": [0, 0, 0], "radius": "banana"}})
    with pytest.raises(ValueError, match="class"):
        rayproof.judge(SPHERE, {"class": "sideways"})
    with pytest.raises(ValueError, match="precision"):
        rayproof.judge(SPHERE, {"class": "miss"}, precision="half")


def random_triangle_queries(n, seed=7):
    rng = np.random.default_rng(seed)
    tri = rng.uniform(-1, 1, (n, 9))
    origins = rng.uniform(-3, 3, (n, 3))
    targets = tri[:, 0:3] * 0.3 + tri[:, 3:6] * 0.3 + tri[:, 6:9] * 0.4 + rng.normal(0, 0.2, (n, 3))
    return origins, targets - origins, tri


def test_judge_many_is_judge_row_by_row():
    origins, directions, tri = random_triangle_queries(300)
    many = rayproof.judge_many("triangle", origins, directions, tri, threads=2)
    assert many["class"].shape == (300,) and many["t"].dtype == np.float64
    hits = 0
    for i in range(300):
        one = rayproof.judge({"ray": {"origin": origins[i].tolist(), "direction": directions[i].tolist()},
                              "shape": {"type": "triangle", "vertices": tri[i].reshape(3, 3).tolist()}})
        assert rayproof.CLASSES[many["class"][i]] == one["class"]
        if one["t"] is None:
            assert np.isnan(many["t"][i])
        else:
            assert many["t"][i] == float.fromhex(one["t"])
            hits += 1
    assert hits > 50  # the rays were aimed: many hit


def test_judge_many_judges_answers_as_judge_does():
    origins, directions, tri = random_triangle_queries(120, seed=11)
    exact = rayproof.judge_many("triangle", origins, directions, tri)
    names = [rayproof.CLASSES[c] for c in exact["class"]]
    # Answers: every third row a wrong class, the rest the exact class with t nudged 0..2 ulps.
    answers, ts = [], []
    for i, (name, t) in enumerate(zip(names, exact["t"])):
        if i % 3 == 0:
            answers.append("miss" if name != "miss" else "enter")
            ts.append(np.nan if name != "miss" else 1.0)
        else:
            answers.append(name)
            ts.append(t if np.isnan(t) else t + (i % 3 - 1) * np.spacing(t))
    many = rayproof.judge_many("triangle", origins, directions, tri, answers, ts)
    assert (many["level"][::3] > 0).all() and (many["agrees"][::3] == 0).all()
    for i in range(120):
        case = {"ray": {"origin": origins[i].tolist(), "direction": directions[i].tolist()},
                "shape": {"type": "triangle", "vertices": tri[i].reshape(3, 3).tolist()}}
        one = rayproof.judge(case, {"class": answers[i], "t": None if np.isnan(ts[i]) else ts[i]})["answer"]
        assert bool(many["agrees"][i] == 2) == one["agrees"], i
        assert many["ulp"][i] == one.get("ulp", -1), i
        level = one.get("level", one.get("level_t"))
        assert many["level"][i] == {None: 0, "rounding": 1, "bug": 2}[level], i
        beta = one.get("beta", one.get("beta_t"))
        if beta is None:
            assert np.isnan(many["beta"][i]), i
        elif isinstance(beta, str):
            assert many["beta"][i] == (np.inf if beta == "none" else -np.inf), i
        else:
            assert float(f"{many['beta'][i]:.2g}") == beta, i
    with pytest.raises(ValueError, match="unknown class 'sideways'"):
        rayproof.judge_many("triangle", origins, directions, tri, ["sideways"] * 120)
    with pytest.raises(ValueError, match="row 5: 9 is not a class code"):
        rayproof.judge_many("triangle", origins, directions, tri, np.where(np.arange(120) == 5, 9, 0))


def test_judge_many_takes_any_layout_and_refuses_bad_arrays():
    origins, directions, tri = random_triangle_queries(50)
    base = rayproof.judge_many("triangle", origins, directions, tri)
    wide = np.zeros((50, 6))
    wide[:, ::2] = origins  # a non-contiguous view
    frozen = directions.copy()
    frozen.setflags(write=False)
    same = rayproof.judge_many("triangle", wide[:, ::2], frozen, np.asfortranarray(tri).astype(np.float32)
                               .astype(np.float64))
    assert (same["class"] == base["class"]).all()
    with pytest.raises(ValueError, match=r"directions: expected shape \(50, 3\)"):
        rayproof.judge_many("triangle", origins, directions[:49], tri)
    with pytest.raises(ValueError, match=r"shapes: expected shape \(50, 9\)"):
        rayproof.judge_many("triangle", origins, directions, tri[:, :6])
    bad = origins.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ValueError, match="row 3"):
        rayproof.judge_many("triangle", bad, directions, tri)
    with pytest.raises(TypeError, match="origins"):
        rayproof.judge_many("triangle", [["a", "b", "c"]], directions[:1], tri[:1])
    with pytest.raises(ValueError, match="unknown shape"):
        rayproof.judge_many("torus", origins, directions, tri)


def test_judging_releases_the_gil():
    rng = np.random.default_rng(1)
    origins, tri = rng.uniform(-3, 3, (300000, 3)), rng.uniform(-1, 1, (300000, 9))
    count, running = [0], [True]

    def counter():
        while running[0]:
            count[0] += 1

    other = threading.Thread(target=counter)
    other.start()
    time.sleep(0.01)
    before = count[0]
    rayproof.judge_many("triangle", origins, -origins, tri, threads=1)  # ~40 ms of C++
    during = count[0] - before
    running[0] = False
    other.join()
    # Held, the GIL would let the counter run only at the call's ends (the 5 ms switch interval
    # needs bytecode to hand it over); released, the counter runs throughout.
    assert during > 10000, during


# ---------------------------------------------------------------- variant campaigns
def test_fuzz_variants_and_the_cli_replays_its_findings(tmp_path):
    out = tmp_path / "found.jsonl"
    report = rayproof.fuzz(["moller-trumbore"], families=["grazing"], shapes=["triangle"], count=2000, seed=3,
                           threads=2, output=out)
    tally = report["tallies"]["grazing\tmoller-trumbore"]
    assert tally["cases"] == 2000 and report["output"] == str(out)
    assert report["findings"] and len(report["findings"]) == len(rayproof.read_cases(out))
    lines = [json.loads(line) for line in cli("check", str(out), "--variants", "moller-trumbore",
                                               "--format", "json").stdout.splitlines() if line.startswith("{\"id")]
    assert len(lines) == len(report["findings"])
    for finding, line in zip(report["findings"], lines):
        assert line["exact"]["class"] == finding["expect"]["class"]


def test_fuzz_tallies_are_the_clis(tmp_path):
    args = dict(families=["tangent", "extremes"], shapes=["sphere", "box"], count=1500, seed=9)
    report = rayproof.fuzz(["stable", "slab"], threads=1, **args)
    summary = tmp_path / "s.json"
    cli("fuzz", "--variants", "stable,slab", "--families", "tangent,extremes", "--shapes", "sphere,box",
        "--count", "1500", "--seed", "9", "--threads", "1", "-o", str(tmp_path / "f.jsonl"), "--summary", str(summary))
    assert report["tallies"] == json.load(open(summary))["tallies"]


# ---------------------------------------------------------------- tracers
def test_numpy_tracer_is_judged_and_its_double_hits_shrunk():
    report = rayproof.fuzz_tracer(NumpyTracer(), families=["fans"], count=128)
    near, anyhit = report["tallies"]["fans\tnumpy-mt"], report["tallies"]["fans-any\tnumpy-mt"]
    assert near["cases"] == anyhit["cases"] == 128
    assert near["right"] == 128  # a fan's centre, nearest mode: any of the fan's triangles is right
    assert anyhit["double_hit"] > 0 and anyhit["double_hit_bugs"] == anyhit["double_hit"]
    doubles = [f for f in report["findings"] if f["found"]["kind"] == "double_hit"]
    # Shrunk: a spoke's double hit to the two triangles sharing it (a closed fan's centre keeps
    # its whole fan: opened, the one-hit rule no longer applies there).
    spokes = [f for f in doubles if f["found"]["detail"].startswith("spoke")]
    assert spokes and all(len(f["mesh"]["triangles"]) == 2 for f in spokes)
    assert "double hits" in report["one_hit_rule"]
    replay = rayproof.check(NumpyTracer(), doubles)
    assert kinds(replay, "numpy-mt") == ["double_hit"] * len(doubles)


def serve(name, path=NUMPY_TRACER, cls="NumpyTracer"):
    return f"{name}={sys.executable} -m rayproof.serve {path}:{cls}"


def test_the_cli_replays_what_python_found_and_the_reverse(tmp_path):
    py = tmp_path / "py.jsonl"
    found = rayproof.fuzz_tracer(NumpyTracer(), families=["shared-edges"], count=64, output=py)["findings"]
    assert found
    lines = [json.loads(line) for line in cli("check", str(py), "--tracer-exec", serve("numpy-mt"),
                                               "--format", "json").stdout.splitlines() if line.startswith("{\"id")]
    assert kinds(lines, "numpy-mt") == [f["found"]["kind"] for f in found]
    clif = tmp_path / "cli.jsonl"
    cli("fuzz", "--tracer-exec", serve("numpy-mt"), "--families", "fans", "--count", "64", "-o", str(clif),
        "--threads", "1")
    from_cli = rayproof.read_cases(clif)
    assert from_cli
    # The campaign itself is the same either way: every count of every row.
    summary = tmp_path / "s.json"
    cli("fuzz", "--tracer-exec", serve("numpy-mt"), "--families", "fans", "--count", "64", "-o", str(clif),
        "--threads", "1", "--summary", str(summary))
    module = rayproof.fuzz_tracer(NumpyTracer(), families=["fans"], count=64)["tallies"]
    timing = ("ns_per_ray", "seconds")
    for key, tally in json.load(open(summary))["tallies"].items():
        assert {k: v for k, v in tally.items() if k not in timing} == \
               {k: v for k, v in module[key].items() if k not in timing}, key
    assert kinds(rayproof.check(NumpyTracer(), clif), "numpy-mt") == [f["found"]["kind"] for f in from_cli]


class Raising(NumpyTracer):
    name = "raising"

    def nearest(self, origins, directions, tmin, tmax):
        if len(self.v0) > 2:
            raise ZeroDivisionError("a mesh of more than two triangles")
        return super().nearest(origins, directions, tmin, tmax)


def test_a_tracer_that_raises_is_a_finding_with_its_traceback():
    report = rayproof.fuzz_tracer(Raising(), families=["fans"], count=64)
    tally = report["tallies"]["fans\traising"]
    assert tally["crash"] == 1
    crash = [f for f in report["findings"] if f["found"]["kind"] == "crash"]
    assert len(crash) == 1
    assert "ZeroDivisionError: a mesh of more than two triangles" in crash[0]["found"]["reason"]
    assert "Traceback" in crash[0]["found"]["reason"]


class WrongLength(NumpyTracer):
    name = "wrong-length"

    def nearest(self, origins, directions, tmin, tmax):
        triangles, t = super().nearest(origins, directions, tmin, tmax)
        return triangles[:-1], t[:-1]


class OutOfRange(NumpyTracer):
    name = "out-of-range"

    def nearest(self, origins, directions, tmin, tmax):
        triangles, t = super().nearest(origins, directions, tmin, tmax)
        return np.where(triangles >= 0, triangles + 1000, -1), t


class Floats(NumpyTracer):
    name = "float-t"

    def nearest(self, origins, directions, tmin, tmax):
        triangles, t = super().nearest(origins, directions, tmin, tmax)
        return triangles.astype(np.float64), t


class Declines(NumpyTracer):
    name = "declines"

    def build(self, vertices, triangles):
        super().build(vertices, triangles)
        return None


class BuildRaises(NumpyTracer):
    name = "build-raises"

    def build(self, vertices, triangles):
        vertices[0, 0] = 1.0  # the arrays are read-only: ValueError


@pytest.mark.parametrize("tracer,kind,field", [(WrongLength(), "tracer_errors", "nearest returned 0 triangles for 1 ray"),
                                               (OutOfRange(), "tracer_errors", None),
                                               (Floats(), "tracer_errors", "must be integers"),
                                               (Declines(), "build_failed", None),
                                               (BuildRaises(), "crash", "read-only")])
def test_bad_tracers_are_counted_never_a_crash(tracer, kind, field):
    report = rayproof.fuzz_tracer(tracer, families=["fans"], count=64)
    tally = report["tallies"][f"fans\t{tracer.name}"]
    assert tally[kind] >= 1 and tally["right"] == 0
    if field:
        assert any(field in f["found"].get("reason", "") for f in report["findings"])


def test_threads_share_a_tracer_that_keeps_its_mesh_in_self():
    one = rayproof.fuzz_tracer(NumpyTracer(), families=["needles", "fans"], count=256, threads=1)
    two = rayproof.fuzz_tracer(NumpyTracer(), families=["needles", "fans"], count=256, threads=2)
    strip = ("ns_per_ray", "seconds")
    for key, tally in one["tallies"].items():
        assert {k: v for k, v in tally.items() if k not in strip} == \
               {k: v for k, v in two["tallies"][key].items() if k not in strip}, key


class Float32Tracer(NumpyTracer):
    name = "numpy-f32"
    precision = "float"

    def build(self, vertices, triangles):
        assert (vertices.astype(np.float32).astype(np.float64) == vertices).all()  # given float-rounded numbers
        return super().build(vertices.astype(np.float32), triangles)


def test_a_float_tracer_is_given_float_numbers():
    report = rayproof.fuzz_tracer(Float32Tracer(), families=["far"], count=128)
    tally = report["tallies"]["far\tnumpy-f32"]
    assert tally["crash"] == 0 and tally["cases"] == 128


def test_fuzz_tracer_refuses_what_it_cannot_run():
    with pytest.raises(TypeError, match="build"):
        rayproof.fuzz_tracer(object())
    with pytest.raises(ValueError, match="unknown tracer family"):
        rayproof.fuzz_tracer(NumpyTracer(), families=["teapots"])
    with pytest.raises(ValueError, match=r"\[a-z0-9-\]"):
        rayproof.fuzz_tracer(NumpyTracer(), name="My Tracer")
    with pytest.raises(ValueError, match="mesh"):
        rayproof.check(NumpyTracer(), [SPHERE])


# ---------------------------------------------------------------- pytest helper
class NearestOnly:
    """The NumPy tracer without its any-hit mode (which reports shared edges twice)."""
    name = "nearest-only"

    def __init__(self):
        self.inner = NumpyTracer()

    def build(self, vertices, triangles):
        self.inner.build(vertices, triangles)
        return self

    def nearest(self, *rays):
        return self.inner.nearest(*rays)


def test_assert_no_bugs_passes_a_right_tracer(tmp_path):
    report = assert_no_bugs(NearestOnly(), families=["fans", "needles"], count=128, findings=tmp_path / "f.jsonl")
    assert report["tallies"]["fans\tnearest-only"]["right"] == 128
    assert report["tallies"]["fans-any\tnearest-only"]["unsupported"] == 128


def test_assert_no_bugs_fails_with_the_shrunk_case_and_its_replay(tmp_path):
    with pytest.raises(AssertionError) as failure:
        assert_no_bugs(NumpyTracer(), families=["fans"], count=128, findings=tmp_path / "f.jsonl")
    message = str(failure.value)
    assert "double_hit in family fans, shrunk to" in message
    assert f"rayproof check {tmp_path / 'f.jsonl'} --tracer-exec numpy-mt=" in message
    shrunk = json.loads(message.split("shrunk to", 1)[1].splitlines()[1])
    assert kinds(rayproof.check(NumpyTracer(), shrunk), "numpy-mt") == ["double_hit"]


# ---------------------------------------------------------------- Open3D, where installed
def test_open3d_raycasting_scene_is_judged_on_every_family():
    pytest.importorskip("open3d", reason="Open3D absent (Debian python3-open3d): the example is not judged")
    from open3d_tracer import Open3DTracer
    report = rayproof.fuzz_tracer(Open3DTracer(), count=64)
    assert {k.split("\t")[0] for k in report["tallies"]} >= set(rayproof.TRACER_FAMILIES)
    for tally in report["tallies"].values():
        assert tally["crash"] == 0 and tally["tracer_errors"] == 0
