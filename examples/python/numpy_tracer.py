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
        v0, v1, v2 = v[t[:, 0]], v[t[:, 1]], v[t[:, 2]]
        self.v0, self.e1, self.e2 = v0.T.copy(), (v1 - v0).T.copy(), (v2 - v0).T.copy()  # (3, T) each
        return self

    def _hits(self, origins, directions, tmin, tmax):
        """t of every ray (rows) against every triangle (columns), inf where it misses; rays in
        chunks of about 2^16 ray-triangle pairs, so the temporaries stay in cache on big meshes."""
        chunk = max(1, 65536 // self.v0.shape[1])
        if len(origins) > chunk:
            return np.vstack([self._hits(origins[i:i + chunk], directions[i:i + chunk], tmin[i:i + chunk],
                                         tmax[i:i + chunk]) for i in range(0, len(origins), chunk)])
        (ox, oy, oz), (dx, dy, dz) = (origins.T[:, :, None], directions.T[:, :, None])
        (e1x, e1y, e1z), (e2x, e2y, e2z) = self.e1, self.e2
        px, py, pz = dy * e2z - dz * e2y, dz * e2x - dx * e2z, dx * e2y - dy * e2x  # p = d x e2
        det = e1x * px + e1y * py + e1z * pz
        sx, sy, sz = ox - self.v0[0], oy - self.v0[1], oz - self.v0[2]  # s = o - v0
        qx, qy, qz = sy * e1z - sz * e1y, sz * e1x - sx * e1z, sx * e1y - sy * e1x  # q = s x e1
        with np.errstate(divide="ignore", invalid="ignore"):
            inv = 1.0 / det
            u = (sx * px + sy * py + sz * pz) * inv
            v = (dx * qx + dy * qy + dz * qz) * inv
            t = (e2x * qx + e2y * qy + e2z * qz) * inv
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
