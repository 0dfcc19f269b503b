"""Scene objects of the config (`scene.objects`) → what the renderer traces and shades.

Meshes: the visibility stage's `visibility/<object>/geometry.npz` when present (read with
sgpipe.artifacts.visibility, so triangle ids and vertex order match the per-vertex SSDF
coefficients), else `sgpipe.io.mesh` (the same shared loader). Analytic spheres stay analytic
for primary visibility; their SSDF data live on the visibility stage's icosphere, reached per
pixel by a ray from the centre ("proxy" mapping).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sgpipe.artifacts import visibility as contract
from sgpipe.errors import BadInput
from sgpipe.scene.gbuffer import TraceObject, Tracer


def object_rotation(rotate_deg) -> np.ndarray:
    """Rotation about X, then Y, then Z (degrees) → 3×3 matrix Rz·Ry·Rx (scene config)."""
    from sgpipe.io.mesh import object_matrix
    return object_matrix((0.0, 0.0, 0.0), rotate_deg, 1.0)[:3, :3]


def _geometry(vis_dir: Path | None, name: str) -> contract.Geometry | None:
    if vis_dir is None or not (Path(vis_dir) / contract.object_file(name, contract.GEOMETRY)
                               ).is_file():
        return None
    return contract.read_geometry(vis_dir, name)


def load_trace_objects(cfg, vis_dir: str | Path | None = None) -> list[TraceObject]:
    """World-space TraceObjects for `cfg.scene.objects`, in config order."""
    from sgpipe.io.mesh import load_object
    if cfg.scene is None:
        return []
    sub = cfg.visibility.sphere_subdivisions if cfg.visibility else 4
    out = []
    assets: dict = {}            # a glTF file is read once for all its primitives' objects
    for k, spec in enumerate(cfg.scene.objects):
        if spec.sphere_radius is not None:
            out.append(TraceObject.sphere(spec.name, center=spec.translate,
                                          radius=spec.sphere_radius * spec.scale,
                                          rotation=object_rotation(spec.rotate_deg)))
            continue
        g = _geometry(Path(vis_dir) if vis_dir else None, spec.name)
        if g is None:
            g = load_object(spec, k, sphere_subdivisions=sub, assets=assets)
        out.append(TraceObject.mesh(spec.name, g.positions, g.faces, normals=g.normals,
                                    tangents=g.tangents, uvs=repeated_uvs(g.uvs, spec),
                                    handedness=g.handedness))
    return out


def repeated_uvs(uvs, spec):
    """The mesh's UVs × the object's `uv_repeat` (texture tiling; tangents ∂p/∂u keep their
    direction under a positive scale, so they stay valid)."""
    rep = tuple(getattr(spec, "uv_repeat", (1.0, 1.0)))
    if uvs is None or rep == (1.0, 1.0):
        return uvs
    return np.asarray(uvs, np.float64) * np.asarray(rep, np.float64)


def load_vis_objects(cfg, vis_dir: str | Path | None):
    """Per object: (VisObject | None, proxy TraceObject | None) from `visibility/<object>/`."""
    from sgpipe.render.renderer import VisObject
    out = []
    for spec in (cfg.scene.objects if cfg.scene is not None else []):
        if vis_dir is None:
            out.append((None, None))
            continue
        folder = Path(vis_dir) / spec.name
        if not (folder / contract.SSDF_PCA).is_file():
            raise BadInput("visibility data missing for this object (rerun `sgpipe "
                           "precompute`)", file=folder, key=f"scene.objects.{spec.name}")
        pca = contract.read_ssdf_pca(vis_dir, spec.name)
        g = _geometry(Path(vis_dir), spec.name)
        if g is None:
            raise BadInput(f"{contract.GEOMETRY} missing", file=folder,
                           key=f"visibility.{spec.name}")
        vis = VisObject(faces=np.asarray(g.faces, np.int32),
                        coeffs=np.asarray(pca.coeffs, np.float32),
                        mean=np.asarray(pca.mean, np.float32),
                        basis=np.asarray(pca.basis, np.float32),
                        max_distance=pca.max_distance)
        proxy = None
        if spec.sphere_radius is not None:
            proxy = TraceObject.mesh(spec.name, g.positions, g.faces)
        out.append((vis, proxy))
    return out


def ssdf_triangles(gb, objects: list[TraceObject], proxies: list):
    """Per pixel (SSDF-mesh triangle, barycentrics): the traced triangle on meshes; on
    analytic spheres the proxy icosphere triangle hit by the ray centre → hit point."""
    tri = gb.triangle_id.copy()
    bary = gb.barycentrics.copy()
    for k, (obj, proxy) in enumerate(zip(objects, proxies)):
        if proxy is None or obj.kind != "sphere":
            continue
        sel = gb.object_id == k
        if not sel.any():
            continue
        c = np.asarray(obj.center, float)
        d = gb.position[sel].astype(float) - c
        p = Tracer([proxy]).trace(np.broadcast_to(c, d.shape), d)
        tri[sel] = np.where(p.hit, p.triangle_id, -1)
        bary[sel] = p.barycentrics
    return tri, bary
