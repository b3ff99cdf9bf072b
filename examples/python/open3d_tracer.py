"""Open3D's ray casting (open3d.t.geometry.RaycastingScene, Embree 3 inside) as users have it:
float32 meshes and rays, no any-hit list. RaycastingScene has no tmin or tmax, so this adapter
does what its users do — starts a ray with tmin > 0 at origin + tmin·direction (then adds tmin
back to t) and keeps hits with t <= tmax — and is judged with that, as code that calls Open3D is.

    import rayproof
    from open3d_tracer import Open3DTracer
    print(rayproof.fuzz_tracer(Open3DTracer(), count=640)["table"])
"""
import numpy as np
import open3d as o3d

INVALID_ID = o3d.t.geometry.RaycastingScene.INVALID_ID


class Open3DTracer:
    name = "open3d"
    precision = "float"  # Open3D takes Float32 tensors: rayproof gives it float-rounded numbers
    range = "closed"     # Embree reports tnear <= t <= tfar

    def build(self, vertices, triangles):
        self.scene = o3d.t.geometry.RaycastingScene()
        self.scene.add_triangles(o3d.core.Tensor(np.asarray(vertices, dtype=np.float32)),
                                 o3d.core.Tensor(np.asarray(triangles, dtype=np.uint32)))
        return self

    def nearest(self, origins, directions, tmin, tmax):
        start = origins + np.where(tmin > 0, tmin, 0)[:, None] * directions  # the user's offset, in double
        rays = np.hstack([start, directions]).astype(np.float32)
        hit = self.scene.cast_rays(o3d.core.Tensor(rays))
        t = hit["t_hit"].numpy().astype(np.float64) + np.where(tmin > 0, tmin, 0)
        ids = hit["primitive_ids"].numpy().astype(np.int64)
        found = (ids != INVALID_ID) & (t <= tmax)
        return np.where(found, ids, -1), np.where(found, t, np.nan)


if __name__ == "__main__":  # python3 open3d_tracer.py [RAYS_PER_FAMILY [FINDINGS]]
    import sys

    import rayproof

    count = int(sys.argv[1]) if len(sys.argv) > 1 else 640
    findings = sys.argv[2] if len(sys.argv) > 2 else "open3d.jsonl"
    report = rayproof.fuzz_tracer(Open3DTracer(), count=count, output=findings)
    print(f"Open3D {o3d.__version__}, {count} rays per family")
    print(report["table"], end="")  # the verdict table, the one-hit rule's line and the diagnosis
    print(f"{len(report['findings'])} findings in {findings}; replay: rayproof.check(Open3DTracer(), {findings!r})")
