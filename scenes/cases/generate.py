#!/usr/bin/env python3
"""Builds the bundled audit suite: hand-constructed cases whose `expect` comes from this
file's own exact rational arithmetic (Python's fractions), independent of the C++ oracle.

Run from anywhere: python3 scenes/cases/generate.py  (rewrites the *.jsonl beside it).
Every number written is a double; the expectations treat those doubles as exact rationals,
as docs/spec/cases.md requires.
"""
import json
import math
import os
import struct
from fractions import Fraction as F

HERE = os.path.dirname(os.path.abspath(__file__))
DBL_MAX = F(struct.unpack('<d', struct.pack('<Q', 0x7FEFFFFFFFFFFFFF))[0])
TWO_1024 = F(2) ** 1024


# ----------------------------------------------------------------------------- numbers
def num(x):
    """A JSON value naming the double x exactly."""
    x = float(x)
    if x == 0 and math.copysign(1, x) < 0:
        return "-0x0p+0"
    if x == int(x) and abs(x) < 2 ** 53:
        return int(x)
    if float(repr(x)) == x and len(repr(x)) <= 12:
        return x
    return x.hex()


def vec(v):
    return [num(c) for c in v]


def next_up(x):
    return math.nextafter(x, math.inf)


def next_down(x):
    return math.nextafter(x, -math.inf)


def q(x):
    return F(x) if not math.isinf(x) else (TWO_1024 if x > 0 else -TWO_1024)


def is_even(x):
    return struct.unpack('<Q', struct.pack('<d', x))[0] & 1 == 0


def sign(x):
    return (x > 0) - (x < 0)


class Quadratic:
    """t = (p + s*sqrt(D)) / a with a > 0."""

    def __init__(self, p, s, D, a):
        self.p, self.s, self.D, self.a = p, s, D, a

    def cmp(self, m):
        # sign(t - m) = sign(R + s sqrt D), R = p - m a
        R = self.p - m * self.a
        if self.s == 0 or self.D == 0:
            return sign(R)
        if self.s > 0:
            if R >= 0:
                return 1
            return sign(self.D - R * R)
        if R <= 0:
            return -1
        return sign(R * R - self.D)

    def approx(self):
        # sqrt(D) to ~200 bits with integers, enough for a starting candidate
        scale = 2 ** 400
        r = F(math.isqrt(self.D.numerator * self.D.denominator * scale * scale), self.D.denominator * scale)
        return (self.p + self.s * r) / self.a


def round_exact(t):
    """Correctly rounded double (ties to even) of a Fraction or a Quadratic t > 0."""
    if isinstance(t, F):
        t = Quadratic(t, 0, F(0), F(1))
    approx = t.approx()
    try:
        x = float(approx)
    except OverflowError:
        x = math.inf
    for _ in range(200):
        if math.isinf(x):
            if t.cmp((DBL_MAX + TWO_1024) / 2) >= 0:
                return x
            x = float(DBL_MAX)
            continue
        lo, hi = next_down(x), next_up(x)
        c = t.cmp((q(lo) + q(x)) / 2)
        if c < 0:
            x = lo
            continue
        if c == 0:
            return x if is_even(x) else lo
        c = t.cmp((q(x) + q(hi)) / 2)
        if c > 0:
            x = hi
            continue
        if c == 0:
            return x if is_even(x) else hi
        return x
    raise RuntimeError("rounding did not converge")


def dot(a, b):
    return sum(F(x) * F(y) for x, y in zip(a, b))


def sub(a, b):
    return [F(x) - F(y) for x, y in zip(a, b)]


def cross(a, b):
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


# ----------------------------------------------------------------------------- exact classes
def sphere_truth(o, d, m, r):
    f = sub(o, m)
    a = dot(d, d)
    bp = -dot(f, d)
    c = dot(f, f) - F(r) * F(r)
    D = bp * bp - a * c
    if D < 0:
        return "miss", None
    if D == 0:
        return ("tangent", bp / a) if bp > 0 else ("miss", None)
    if c > 0:
        return ("enter", Quadratic(bp, -1, D, a)) if bp > 0 else ("miss", None)
    if c == 0:
        return ("exit", 2 * bp / a) if bp > 0 else ("miss", None)
    return "exit", Quadratic(bp, 1, D, a)


def plane_truth(o, d, n, k):
    den = dot(n, d)
    numr = F(k) - dot(n, o)
    if den == 0:
        return ("tangent", None) if numr == 0 else ("miss", None)
    t = numr / den
    if t <= 0:
        return "miss", None
    return ("enter" if den < 0 else "exit"), t


def point_in_triangle_2d(p, a, b, c):
    """Barycentric weights of p in the 2D triangle abc (exact); None if degenerate."""
    det = (b[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (b[1] - a[1])
    w1 = ((p[0] - a[0]) * (c[1] - a[1]) - (c[0] - a[0]) * (p[1] - a[1])) / det
    w2 = ((b[0] - a[0]) * (p[1] - a[1]) - (p[0] - a[0]) * (b[1] - a[1])) / det
    return 1 - w1 - w2, w1, w2


def triangle_truth(o, d, v):
    v = [[F(x) for x in p] for p in v]
    o = [F(x) for x in o]
    d = [F(x) for x in d]
    n = cross(sub(v[1], v[0]), sub(v[2], v[0]))
    drop = max(range(3), key=lambda i: abs(n[i]))
    keep = [i for i in range(3) if i != drop]
    proj = lambda p: [p[keep[0]], p[keep[1]]]
    den = dot(n, d)
    if den == 0:
        if dot(n, sub(v[0], o)) != 0:
            return "miss", None
        # coplanar: walk in 2D
        w = point_in_triangle_2d(proj(o), *map(proj, v))
        if min(w) >= 0:
            eps_ok = True  # does o + εd stay inside? check every edge whose weight is 0
            dw = point_in_triangle_2d([proj(o)[0] + proj(d)[0], proj(o)[1] + proj(d)[1]], *map(proj, v))
            for wi, dwi in zip(w, dw):
                if wi == 0 and dwi - wi < 0:
                    eps_ok = False
            return ("tangent", None) if eps_ok else ("miss", None)
        best = None
        for i in range(3):
            a, b = proj(v[i]), proj(v[(i + 1) % 3])
            e = [b[0] - a[0], b[1] - a[1]]
            dd = proj(d)
            det = dd[0] * e[1] - dd[1] * e[0]
            if det == 0:
                continue
            ao = [a[0] - proj(o)[0], a[1] - proj(o)[1]]
            t = (ao[0] * e[1] - ao[1] * e[0]) / det
            u = (ao[0] * dd[1] - ao[1] * dd[0]) / det
            if t > 0 and 0 <= u <= 1 and (best is None or t < best):
                best = t
        return ("tangent", best) if best is not None else ("miss", None)
    t = dot(n, sub(v[0], o)) / den
    if t <= 0:
        return "miss", None
    p = [o[i] + t * d[i] for i in range(3)]
    w = point_in_triangle_2d(proj(p), *map(proj, v))
    if min(w) < 0:
        return "miss", None
    if min(w) == 0:
        return "boundary", t
    return ("enter" if den < 0 else "exit"), t


def box_truth(o, d, lo, hi):
    tmin, tmax = None, None
    strictly_inside_flat = True
    for i in range(3):
        oi, di, a, b = F(o[i]), F(d[i]), F(lo[i]), F(hi[i])
        if di == 0:
            if oi < a or oi > b:
                return "miss", None
            if oi == a or oi == b:
                strictly_inside_flat = False
            continue
        t1, t2 = (a - oi) / di, (b - oi) / di
        near, far = min(t1, t2), max(t1, t2)
        tmin = near if tmin is None else max(tmin, near)
        tmax = far if tmax is None else min(tmax, far)
    if tmin > tmax or tmax <= 0:
        return "miss", None
    if tmin < tmax and strictly_inside_flat:
        return ("enter", tmin) if tmin > 0 else ("exit", tmax)
    return ("tangent", tmin) if tmin > 0 else ("tangent", None)


# ----------------------------------------------------------------------------- families
def make_case(cid, o, d, shape, truth, family):
    cls, t = truth
    expect = {"class": cls}
    if t is not None:
        expect["t"] = float.hex(round_exact(t)) if not math.isinf(round_exact(t)) else "inf"
    return {"id": cid, "ray": {"origin": vec(o), "direction": vec(d)}, "shape": shape,
            "expect": expect, "found": {"family": family, "source": "scenes/cases/generate.py"}}


SCALES = [-500, -64, 0, 64, 500]


def scaled(v, k):
    return [math.ldexp(float(x), k) for x in v]


def sphere_cases():
    out = []
    # Points on spheres with rational coordinates: Pythagorean quadruples (x,y,z,r).
    quads = [(3, 4, 0, 5), (1, 2, 2, 3), (2, 3, 6, 7), (1, 4, 8, 9), (2, 6, 9, 11), (0, 0, 1, 1)]
    centers = [(0, 0, 0), (1, 0, 1), (-3, 5, 2), (0.5, -0.25, 8)]
    for qi, (x, y, z, r) in enumerate(quads):
        for ci, m in enumerate(centers):
            for k in SCALES:
                P = [m[0] + x, m[1] + y, m[2] + z]
                nrm = [x, y, z]
                # a tangent direction: nrm x axis (exactly perpendicular)
                axis = [0, 0, 1] if (x, y) != (0, 0) else [1, 0, 0]
                tan = [nrm[1] * axis[2] - nrm[2] * axis[1], nrm[2] * axis[0] - nrm[0] * axis[2],
                       nrm[0] * axis[1] - nrm[1] * axis[0]]
                rays = {
                    "enter-through-point": ([P[i] + 2 * nrm[i] for i in range(3)], [-n for n in nrm]),
                    "tangent": ([P[i] - 3 * tan[i] for i in range(3)], tan),
                    "tangent-behind": ([P[i] + 3 * tan[i] for i in range(3)], tan),
                    "on-surface-inward": (P, [-n for n in nrm]),
                    "on-surface-outward": (P, nrm),
                    "on-surface-along-tangent": (P, tan),
                    "inside-exit": (m, nrm),
                    "miss-beside": ([P[i] + nrm[i] - 3 * tan[i] for i in range(3)], tan),
                }
                for name, (o, d) in rays.items():
                    o2, d2, m2, r2 = scaled(o, k), scaled(d, k), scaled(m, k), math.ldexp(r, k)
                    shape = {"type": "sphere", "center": vec(m2), "radius": num(r2)}
                    cid = f"sphere-q{qi}-c{ci}-s{k}-{name}"
                    out.append(make_case(cid, o2, d2, shape, sphere_truth(o2, d2, m2, r2), "sphere-" + name))
                # the tangent ray nudged by one ulp either way in the origin's normal component
                o = [P[i] - 3 * tan[i] for i in range(3)]
                for sgn_, step in (("in", next_down), ("out", next_up)):
                    ax = max(range(3), key=lambda i: abs(nrm[i]))
                    o2 = list(scaled(o, k))
                    o2[ax] = step(o2[ax]) if nrm[ax] > 0 else (next_up(o2[ax]) if step is next_down else next_down(o2[ax]))
                    d2, m2, r2 = scaled(tan, k), scaled(m, k), math.ldexp(r, k)
                    shape = {"type": "sphere", "center": vec(m2), "radius": num(r2)}
                    cid = f"sphere-q{qi}-c{ci}-s{k}-tangent-ulp-{sgn_}"
                    out.append(make_case(cid, o2, d2, shape, sphere_truth(o2, d2, m2, r2), "sphere-near-tangent"))
    # A small sphere far away (Ray Tracing Gems ch. 7) and one beyond b² overflow.
    for dist in (1e6, 1e9, 1e12, 1e15, 1e200, 1e300):
        o, d, m, r = [0, 0, 0], [1, 0, 0], [dist, 0.5 * dist / 1e6, 0], dist / 1e6
        shape = {"type": "sphere", "center": vec(m), "radius": num(r)}
        out.append(make_case(f"sphere-far-{dist:g}", o, d, shape, sphere_truth(o, d, m, r), "sphere-far-small"))
    return out


def plane_cases():
    out = []
    normals = [(0, 0, 1), (0, 2, 0), (1, 1, 1), (3, -4, 12), (1, 0.5, -0.25)]
    for ni, n in enumerate(normals):
        for k in SCALES:
            for name, o, d, off in [
                ("front", [0, 0, 0], [-x for x in n], -7),
                ("back", [0, 0, 0], list(n), 5),
                ("parallel", [1, 2, 3], [n[1], -n[0], 0] if (n[0], n[1]) != (0, 0) else [1, 0, 0], 1),
                ("in-plane", [0, 0, 0], [n[1], -n[0], 0] if (n[0], n[1]) != (0, 0) else [1, 0, 0], 0),
                ("t-zero", [0, 0, 0], list(n), 0),
                ("behind", [0, 0, 0], list(n), -3),
                ("third", [0, 0, 0], [3 * x for x in n], 1),
            ]:
                o2, d2, off2 = scaled(o, k), scaled(d, k), math.ldexp(off, k)
                shape = {"type": "plane", "normal": vec(n), "offset": num(off2)}
                out.append(make_case(f"plane-n{ni}-s{k}-{name}", o2, d2, shape, plane_truth(o2, d2, n, off2),
                                     "plane-" + name))
    return out


def triangle_cases():
    out = []
    tris = [[(0, 0, 0), (4, 0, 0), (0, 4, 0)], [(1, 1, 1), (5, 2, 1), (2, 6, 3)],
            [(-2, 0, 1), (2, -1, 3), (0, 3, -2)]]
    for ti, v in enumerate(tris):
        n = cross(sub(v[1], v[0]), sub(v[2], v[0]))
        n = [float(x) for x in n]
        e01 = [(F(v[0][i]) + F(v[1][i])) / 2 for i in range(3)]
        centroid = [(F(v[0][i]) + F(v[1][i]) + F(v[2][i])) / 3 for i in range(3)]
        inner = [(2 * F(v[0][i]) + F(v[1][i]) + F(v[2][i])) / 4 for i in range(3)]
        outside = [2 * F(v[1][i]) - F(v[0][i]) for i in range(3)]
        for k in SCALES:
            targets = {"edge-midpoint": e01, "vertex": v[2], "interior": inner, "outside": outside,
                       "centroid-ish": centroid}
            for tname, target in targets.items():
                for side, dsign in (("front", -1), ("back", 1)):
                    d = [dsign * x for x in n]
                    o = [float(target[i]) - d[i] for i in range(3)]
                    o2, d2 = scaled(o, k), scaled(d, k)
                    verts = [scaled(p, k) for p in v]
                    shape = {"type": "triangle", "vertices": [vec(p) for p in verts]}
                    out.append(make_case(f"triangle-{ti}-s{k}-{tname}-{side}", o2, d2, shape,
                                         triangle_truth(o2, d2, verts), "triangle-" + tname))
            # coplanar rays: from outside through the edge v0v1's midpoint, and from inside
            for cname, o, d in [
                ("coplanar-cross", [2 * float(e01[i]) - float(centroid[i]) for i in range(3)],
                 [float(centroid[i] - e01[i]) for i in range(3)]),
                ("coplanar-inside", [float(x) for x in inner], [float(v[1][i]) - float(v[0][i]) for i in range(3)]),
                ("coplanar-vertex-out", list(v[0]), [float(v[0][i]) - float(v[1][i]) for i in range(3)]),
            ]:
                o2, d2 = scaled(o, k), scaled(d, k)
                verts = [scaled(p, k) for p in v]
                if any(float(F(x)) != x for x in o2):
                    continue
                shape = {"type": "triangle", "vertices": [vec(p) for p in verts]}
                out.append(make_case(f"triangle-{ti}-s{k}-{cname}", o2, d2, shape,
                                     triangle_truth(o2, d2, verts), "triangle-" + cname))
    return out


def box_cases():
    out = []
    boxes = [((0, 0, 0), (2, 2, 2)), ((-1, -3, 0.5), (4, 1, 2.5))]
    for bi, (lo, hi) in enumerate(boxes):
        mid = [(a + b) / 2 for a, b in zip(lo, hi)]
        for k in SCALES:
            rays = {
                "face": ([lo[0] - 1, mid[1], mid[2]], [1, 0, 0]),
                "inside": (mid, [0, 0, 1]),
                "on-face-in": ([lo[0], mid[1], mid[2]], [1, 0, 0]),
                "on-face-out": ([lo[0], mid[1], mid[2]], [-1, 0, 0]),
                "corner-in": (list(lo), [1, 1, 1]),
                "along-edge": ([lo[0] - 1, lo[1], lo[2]], [1, 0, 0]),
                "along-face-outside": ([lo[0] - 1, mid[1], lo[2]], [1, 0, 0]),
                "along-face-on": ([mid[0], mid[1], lo[2]], [1, 0, 0]),
                "touch-edge": ([lo[0] - 1, lo[1] + 1, mid[2]], [1, -1, 0]),
                "touch-corner": ([lo[0] - 1, lo[1] - 1, hi[2] + 1], [1, 1, -1]),
                "through-edge": ([lo[0] - 1, lo[1] - 1, mid[2]], [1, 1, 0]),
                "negative-zero": ([lo[0] - 1, mid[1], mid[2]], [1, -0.0, -0.0]),
                "behind": ([hi[0] + 1, mid[1], mid[2]], [1, 0, 0]),
            }
            for name, (o, d) in rays.items():
                o2, d2 = scaled(o, k), scaled(d, k)
                lo2, hi2 = scaled(lo, k), scaled(hi, k)
                shape = {"type": "box", "min": vec(lo2), "max": vec(hi2)}
                out.append(make_case(f"box-{bi}-s{k}-{name}", o2, d2, shape, box_truth(o2, d2, lo2, hi2),
                                     "box-" + name))
            # one ulp beyond and within the touched edge
            for side, step in (("out", next_down), ("in", next_up)):
                o = scaled([lo[0] - 1, lo[1] + 1, mid[2]], k)
                o[1] = step(o[1])
                d = scaled([1, -1, 0], k)
                lo2, hi2 = scaled(lo, k), scaled(hi, k)
                shape = {"type": "box", "min": vec(lo2), "max": vec(hi2)}
                out.append(make_case(f"box-{bi}-s{k}-touch-edge-ulp-{side}", o, d, shape,
                                     box_truth(o, d, lo2, hi2), "box-near-edge"))
    return out


def main():
    for name, cases in [("sphere", sphere_cases()), ("plane", plane_cases()), ("triangle", triangle_cases()),
                        ("box", box_cases())]:
        path = os.path.join(HERE, f"{name}.jsonl")
        with open(path + ".tmp", "w") as f:
            for c in cases:
                f.write(json.dumps(c) + "\n")
        os.replace(path + ".tmp", path)
        classes = {}
        for c in cases:
            classes[c["expect"]["class"]] = classes.get(c["expect"]["class"], 0) + 1
        print(f"{path}: {len(cases)} cases {classes}")


if __name__ == "__main__":
    main()
