"""A whole tracer in NumPy: Möller–Trumbore (1997) vectorised over every triangle and every ray
of a batch, brute force, no acceleration structure — the prototype people write before porting
to C++. Edges inclusive (u, v >= 0, u + v <= 1), a zero determinant a miss, t in (tmin, tmax).

    import rayproof
    from numpy_tracer import NumpyTracer
    print(rayproof.fuzz_tracer(NumpyTracer(), families=["shared-edges"], count=640)["table"])
"""
import numpy as np


class NumpyTracer:
    name = "numpy-mt"
    precision = "double"
    range = "open"

    def build(self, vertices, triangles):
        v = np.asarray(vertices, dtype=np.float64)
        t = np.asarray(triangles, dtype=np.int64)
        self.v0, self.e1, self.e2 = v[t[:, 0]], v[t[:, 1]] - v[t[:, 0]], v[t[:, 2]] - v[t[:, 0]]
        return self

    def _hits(self, origins, directions, tmin, tmax):
        """t of every ray (rows) against every triangle (columns), inf where it misses."""
        d = directions[:, None, :]
        p = np.cross(d, self.e2[None, :, :])
        det = np.einsum("ntk,tk->nt", p, self.e1)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = origins[:, None, :] - self.v0[None, :, :]
            u = np.einsum("ntk,ntk->nt", s, p) / det
            q = np.cross(s, self.e1[None, :, :])
            v = np.einsum("nk,ntk->nt", directions, q) / det
            t = np.einsum("ntk,tk->nt", q, self.e2) / det
            ok = (det != 0) & (u >= 0) & (v >= 0) & (u + v <= 1) & (t > tmin[:, None]) & (t < tmax[:, None])
        return np.where(ok, t, np.inf)

    def nearest(self, origins, directions, tmin, tmax):
        t = self._hits(origins, directions, tmin, tmax)
        best = np.argmin(t, axis=1)
        tbest = t[np.arange(len(t)), best]
        return np.where(np.isfinite(tbest), best, -1), tbest

    def all_hits(self, origins, directions, tmin, tmax):
        t = self._hits(origins, directions, tmin, tmax)
        return [np.flatnonzero(np.isfinite(row)).tolist() for row in t]
