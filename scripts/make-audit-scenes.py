#!/usr/bin/env python3
"""Writes the adversarial meshes of scenes/audit/ (committed; rerun to regenerate).

edge-grid.off: a planar triangle mesh at z = 1 whose vertices sit exactly on primary rays of
scenes/audit/edge-grid.json's camera (window form, eye at the origin, 128x64 pixels, window
[-2, 2] x [2.5, -2.5]): pixel (i, j)'s ray leaves along (-sx, sy, 1) with sx = -2 + (i + 1/2)/32 and
sy = 2.5 - 5(j + 1/2)/64, all exact in binary, and meets the plane z = 1 at t = 1. Every pixel row is
a row of vertices (every third pixel, shifted from row to row) joined by edges, and strips of
triangles fill the space between consecutive rows: every primary ray meets an edge or a vertex
exactly, the exact image is all mesh, and any hole is the variant's. The rows extend one pixel
beyond the image on each side, so no ray meets the mesh's boundary. A point on a row edge lies at
1/3 or 2/3 along it, and each triangle lists first the vertex opposite its row edge, so that edge
is Moller-Trumbore's u + v = 1 edge in both triangles sharing it (a legal, common ordering): an
intersector that divides by the determinant rounds there, one that compares edge functions
(watertight) decides both triangles alike.

edge-grid-tilted.off: the same strips for edge-grid-tilted.json's look-at camera (eye
(0.3, -0.2, 0.1), looking at (1.1, 0.7, 2.3), 96x64 pixels, 50 degrees): each vertex is eye + d with
d a pixel centre's ray direction computed as the renderer does (scene.md), rounded, so vertices and
edges lie within rounding of the pixel rays rather than exactly on them. The mesh covers the whole
view, so the exact image is all mesh again; every ray passes within a few ulps of an edge or
vertex, where code that decides the two triangles of an edge separately can miss both.

terrain.obj: a gently rolling height field lit from just above the horizon, so shadow rays leave
each triangle grazing its neighbours (acne and missed occluders).
"""
import math
import pathlib

out = pathlib.Path(__file__).resolve().parent.parent / "scenes" / "audit"
out.mkdir(parents=True, exist_ok=True)


def sx(i):
    return -2 + (i + 0.5) / 32


def sy(j):
    return 2.5 - (j + 0.5) / 64 * 5



def look_at_directions(eye, look_at, up, fov_deg, width, height):
    """Pixel (i, j) -> ray direction, in the renderer's operation order (lib/scene.cpp)."""
    def sub(a, b): return (a[0] - b[0], a[1] - b[1], a[2] - b[2])
    def dot(a, b): return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
    def cross(a, b): return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])
    view = sub(look_at, eye)
    f = (view[0] / math.sqrt(dot(view, view)), view[1] / math.sqrt(dot(view, view)), view[2] / math.sqrt(dot(view, view)))
    side = cross(f, up)
    n = math.sqrt(dot(side, side))
    r = (side[0] / n, side[1] / n, side[2] / n)
    u = cross(r, f)
    half = math.tan(fov_deg * math.pi / 360)
    left, right, top, bottom = -half * (width / height), half * (width / height), half, -half
    def d(i, j):
        x, y = i + 0.5, j + 0.5
        a = left + x / width * (right - left)
        b = top + y / height * (bottom - top)
        return tuple(f[k] + a * r[k] + b * u[k] for k in range(3))
    return d


def strips(point, columns, rows, step=3):
    """Rows of vertices point(i, j) every `step` pixels (shifted per row), zipped into strips."""
    verts, faces, row_ids = [], [], []
    for j in rows:
        ids = []
        for i in range(columns[0] - j % step, columns[1], step):
            ids.append(len(verts))
            verts.append((i, point(i, j)))
        row_ids.append(ids)
    for upper, lower in zip(row_ids, row_ids[1:]):
        p = q = 0
        while p + 1 < len(upper) or q + 1 < len(lower):
            x_up = verts[upper[p + 1]][0] if p + 1 < len(upper) else float("inf")
            x_lo = verts[lower[q + 1]][0] if q + 1 < len(lower) else float("inf")
            if x_up <= x_lo:
                faces.append((lower[q], upper[p], upper[p + 1]))
                p += 1
            else:
                faces.append((upper[p], lower[q + 1], lower[q]))
                q += 1
    return [v for _, v in verts], faces


def write_off(path, verts, faces, comment):
    with open(path, "w") as f:
        f.write(f"OFF\n# scripts/make-audit-scenes.py: {comment}\n{len(verts)} {len(faces)} 0\n")
        for v in verts:
            f.write(" ".join(repr(x) for x in v) + "\n")
        for t in faces:
            f.write("3 " + " ".join(map(str, t)) + "\n")


# Pixel rows -1 .. 64 and columns -3 .. 131: one beyond the image on every side.
gv, gf = strips(lambda i, j: (-sx(i), sy(j), 1.0), (-3, 132), range(-1, 65))
write_off(out / "edge-grid.off", gv, gf, "vertices exactly on pixel rays of edge-grid.json")

eye = (0.3, -0.2, 0.1)
d = look_at_directions(eye, (1.1, 0.7, 2.3), (0.0, 1.0, 0.0), 50, 96, 64)
tv, tf = strips(lambda i, j: tuple(eye[k] + d(i, j)[k] for k in range(3)), (-3, 100), range(-1, 65))
write_off(out / "edge-grid-tilted.off", tv, tf, "vertices within rounding of pixel rays of edge-grid-tilted.json")

n = 48
with open(out / "terrain.obj", "w") as f:
    f.write("# scripts/make-audit-scenes.py: a rolling height field, 48 x 48 cells over [-1, 1]^2\n")
    for r in range(n + 1):
        for c in range(n + 1):
            x, z = -1 + 2 * c / n, -1 + 2 * r / n
            y = 0.04 * math.sin(5 * x + 1) * math.cos(4 * z) + 0.02 * math.sin(11 * x * z)
            f.write(f"v {x!r} {y!r} {z!r}\n")
    for r in range(n):
        for c in range(n):
            a = r * (n + 1) + c + 1
            b, d, e = a + 1, a + n + 1, a + n + 2
            f.write(f"f {a} {d} {e}\nf {a} {e} {b}\n")
print("wrote edge-grid.off, edge-grid-tilted.off and terrain.obj in", out)
