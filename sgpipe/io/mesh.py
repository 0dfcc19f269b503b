"""Scene geometry shared by the visibility and render stages: load, transform, validate,
vertex normals and tangents (CONVENTIONS: tangents from UVs when present, else azimuthal around +Y).

Bad meshes never crash or pass silently: empty meshes, non-finite vertices and meshes with no
usable triangle raise BadInput (naming file and key); degenerate triangles, unreferenced
vertices and unusable normals are repaired and reported as counted warnings.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sgpipe.core.rotation import axis_angle_matrix
from sgpipe.core.sphere import tangent_frame
from sgpipe.errors import BadInput

# A triangle whose area is below this fraction of (bounding-box diagonal)² is degenerate.
_DEGENERATE_REL_AREA = 1e-14


@dataclass
class MeshGeometry:
    """World-space triangle mesh of one scene object, ready for tracing and shading."""

    name: str
    material: str
    positions: np.ndarray            # (V, 3) float64, world
    normals: np.ndarray              # (V, 3) unit
    tangents: np.ndarray             # (V, 3) unit, ⟂ normals
    faces: np.ndarray                # (F, 3) int32
    uvs: np.ndarray                  # (V, 2), zeros when has_uvs is False
    has_uvs: bool
    source: str | None = None
    warnings: dict[str, int] = field(default_factory=dict)
    #: (V,) ±1: a normal texture's +Y runs along handedness · (n × t) (glTF TANGENT.w);
    #: None: +1 everywhere
    handedness: np.ndarray | None = None

    @property
    def bitangents(self) -> np.ndarray:
        """CONVENTIONS: b = n × t."""
        return np.cross(self.normals, self.tangents)

    @property
    def triangles(self) -> np.ndarray:
        """(F, 3, 3) corner positions."""
        return self.positions[self.faces]


def object_matrix(translate=(0.0, 0.0, 0.0), rotate_deg=(0.0, 0.0, 0.0),
                  scale=1.0) -> np.ndarray:
    """4×4 world matrix: uniform scale, then rotate about X, then Y, then Z, then translate."""
    rx, ry, rz = np.radians(np.asarray(rotate_deg, float))
    R = (axis_angle_matrix((0.0, 0.0, 1.0), rz) @ axis_angle_matrix((0.0, 1.0, 0.0), ry)
         @ axis_angle_matrix((1.0, 0.0, 0.0), rx))
    M = np.eye(4)
    M[:3, :3] = R * float(scale)
    M[:3, 3] = np.asarray(translate, float)
    return M


def _transform(M: np.ndarray, positions: np.ndarray, normals: np.ndarray | None):
    p = positions @ M[:3, :3].T + M[:3, 3]
    n = None
    if normals is not None:
        n = normals @ np.linalg.inv(M[:3, :3])   # inverse transpose, row-vector form
    return p, n


def _unit_rows(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Normalised rows and a mask of rows whose length was usable."""
    ln = np.linalg.norm(v, axis=1)
    ok = np.isfinite(ln) & (ln > 1e-20)
    out = np.zeros_like(v)
    out[ok] = v[ok] / ln[ok, None]
    return out, ok


def area_weighted_normals(positions: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Σ over incident faces of (e1 × e2) (= 2·area·face normal), unnormalised, per vertex."""
    tri = positions[faces]
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    acc = np.zeros_like(positions)
    for k in range(3):
        for c in range(3):
            acc[:, c] += np.bincount(faces[:, k], weights=fn[:, c], minlength=len(positions))
    return acc


def uv_tangents(positions, faces, uvs, normals) -> tuple[np.ndarray, np.ndarray]:
    """Per-vertex tangents ∂p/∂u (Lengyel), area-weighted, Gram–Schmidt against n.

    Returns (tangents, ok): ok is False where the UV derivative is degenerate."""
    tri = positions[faces]
    tuv = uvs[faces]
    e1, e2 = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]
    d1, d2 = tuv[:, 1] - tuv[:, 0], tuv[:, 2] - tuv[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    good = np.abs(det) > 1e-20
    r = np.where(good, 1.0 / np.where(good, det, 1.0), 0.0)
    # Weight by |det| so each face contributes ∝ its UV area ⇒ magnitude-consistent sums.
    ft = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) * (r * np.abs(det))[:, None]
    acc = np.zeros_like(positions)
    for k in range(3):
        for c in range(3):
            acc[:, c] += np.bincount(faces[:, k], weights=ft[:, c], minlength=len(positions))
    acc -= np.sum(acc * normals, axis=1, keepdims=True) * normals
    t, ok = _unit_rows(acc)
    ln = np.linalg.norm(acc, axis=1)
    scale = np.median(ln[ok]) if ok.any() else 0.0
    ok &= ln > 1e-6 * scale
    return t, ok


def build_mesh(positions, faces, *, normals=None, uvs=None, tangents=None, name="object",
               material="default", source=None, key=None) -> MeshGeometry:
    """Validate a world-space mesh and complete it with unit normals and tangents (`tangents`
    (V, 4) xyz and handedness w, a glTF file's or MikkTSpace's, where given and usable; else
    from the UVs)."""
    file = source
    P = np.asarray(positions, dtype=np.float64).reshape(-1, 3)
    Fc = np.asarray(faces).reshape(-1, 3) if np.size(faces) else np.zeros((0, 3), np.int64)
    if len(P) == 0 or len(Fc) == 0:
        raise BadInput(f"mesh is empty ({len(P)} vertices, {len(Fc)} triangles)",
                       file=file, key=key)
    bad = ~np.isfinite(P).all(axis=1)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise BadInput(f"{int(bad.sum())} vertices are not finite (first: vertex {i} = "
                       f"{P[i].tolist()})", file=file, key=key)
    if not np.issubdtype(Fc.dtype, np.integer):
        raise BadInput("face indices are not integers", file=file, key=key)
    if Fc.min() < 0 or Fc.max() >= len(P):
        raise BadInput(f"face indices out of range [0, {len(P)})", file=file, key=key)
    warnings: dict[str, int] = {}
    diag = float(np.linalg.norm(P.max(0) - P.min(0)))
    tri = P[Fc]
    area2 = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), axis=1)
    degenerate = ((Fc[:, 0] == Fc[:, 1]) | (Fc[:, 1] == Fc[:, 2]) | (Fc[:, 0] == Fc[:, 2])
                  | (area2 <= 2 * _DEGENERATE_REL_AREA * max(diag, 1e-300) ** 2))
    if degenerate.all():
        raise BadInput(f"all {len(Fc)} triangles are degenerate (zero area)", file=file, key=key)
    if degenerate.any():
        warnings["degenerate_triangles_removed"] = int(degenerate.sum())
        Fc = Fc[~degenerate]
    used = np.zeros(len(P), bool)
    used[Fc.ravel()] = True
    if not used.all():
        warnings["unreferenced_vertices_removed"] = int((~used).sum())
        remap = np.cumsum(used) - 1
        Fc = remap[Fc]
        P = P[used]
        normals = None if normals is None else np.asarray(normals, float).reshape(-1, 3)[used]
        uvs = None if uvs is None else np.asarray(uvs, float).reshape(-1, 2)[used]
        tangents = None if tangents is None else np.asarray(tangents, float).reshape(-1, 4)[used]
    Fc = Fc.astype(np.int32)

    geo_n, geo_ok = _unit_rows(area_weighted_normals(P, Fc))
    if normals is not None:
        N, ok = _unit_rows(np.asarray(normals, float).reshape(-1, 3))
        if (~ok).any():
            warnings["invalid_file_normals_recomputed"] = int((~ok).sum())
        N[~ok] = geo_n[~ok]
        ok = ok | geo_ok
    else:
        N, ok = geo_n, geo_ok
    if (~ok).any():   # incident face normals cancel (e.g. a doubled sheet): first face's normal
        warnings["vertices_with_cancelling_normals"] = int((~ok).sum())
        fn, _ = _unit_rows(np.cross(P[Fc[:, 1]] - P[Fc[:, 0]], P[Fc[:, 2]] - P[Fc[:, 0]]))
        first = np.full(len(P), -1)
        first[Fc[::-1].ravel()] = np.repeat(np.arange(len(Fc))[::-1], 3)
        N[~ok] = fn[first[~ok]]

    has_uvs = uvs is not None and np.isfinite(uvs).all()
    if uvs is not None and not has_uvs:
        warnings["non_finite_uvs_ignored"] = 1
    T_default, _ = tangent_frame(N)
    T = np.asarray(T_default, float)
    if has_uvs:
        UV = np.asarray(uvs, float).reshape(-1, 2)
        T_uv, ok_uv = uv_tangents(P, Fc, UV, N)
        T = np.where(ok_uv[:, None], T_uv, T)
        if (~ok_uv).any():
            warnings["degenerate_uv_tangents_fallback"] = int((~ok_uv).sum())
    else:
        UV = np.zeros((len(P), 2))
    hand = None
    if tangents is not None:
        T4 = np.asarray(tangents, float).reshape(-1, 4)
        given = T4[:, :3] - np.einsum("ij,ij->i", T4[:, :3], N)[:, None] * N
        given, ok_t = _unit_rows(np.nan_to_num(given))
        T = np.where(ok_t[:, None], given, T)
        hand = np.where(ok_t & (T4[:, 3] < 0), -1.0, 1.0)
    return MeshGeometry(name=name, material=material, positions=P, normals=N, tangents=T,
                        faces=Fc, uvs=UV, has_uvs=bool(has_uvs), source=source,
                        warnings=warnings, handedness=hand)


def _read_mesh_file(path: Path, key: str | None):
    """Positions, faces, normals|None, uvs|None of every geometry in a mesh file (node
    transforms applied), concatenated."""
    import trimesh
    try:
        loaded = trimesh.load(str(path), process=False)
    except Exception as e:  # trimesh raises many types for malformed files
        raise BadInput(f"cannot load mesh ({type(e).__name__}: {e})", file=path,
                       key=key) from None
    parts = []
    if isinstance(loaded, trimesh.Trimesh):
        parts.append((np.eye(4), loaded))
    elif isinstance(loaded, trimesh.Scene):
        for node in loaded.graph.nodes_geometry:
            M, gname = loaded.graph[node]
            g = loaded.geometry.get(gname)
            if isinstance(g, trimesh.Trimesh):
                parts.append((np.asarray(M, float), g))
    else:
        raise BadInput(f"not a triangle mesh ({type(loaded).__name__})", file=path, key=key)
    if not parts:
        raise BadInput("mesh is empty (no triangle geometry)", file=path, key=key)
    Ps, Fs, Ns, UVs, off = [], [], [], [], 0
    for M, g in parts:
        v = np.asarray(g.vertices, float)
        f = np.asarray(g.faces)
        # a damaged file can parse into vertices without coordinates or faces past the end
        if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
            raise BadInput(f"malformed mesh (vertices {v.shape}, faces {f.shape})", file=path,
                           key=key)
        out_of_range = f[(f < 0) | (f >= len(v))]
        if out_of_range.size:
            raise BadInput(f"a face refers to vertex index {int(out_of_range[0])} of "
                           f"{len(v)} vertices", file=path, key=key)
        n = g._cache["vertex_normals"] if "vertex_normals" in g._cache else None
        n = None if n is None or np.shape(n) != v.shape else np.asarray(n, float)
        v, n = _transform(M, v, n)
        uv = getattr(g.visual, "uv", None) if g.visual is not None else None
        uv = None if uv is None or len(uv) != len(v) else np.asarray(uv, float)
        Ps.append(v)
        Fs.append(np.asarray(g.faces, np.int64) + off)
        Ns.append(n)
        UVs.append(uv)
        off += len(v)
    P = np.concatenate(Ps) if Ps else np.zeros((0, 3))
    F = np.concatenate(Fs) if Fs else np.zeros((0, 3), np.int64)
    N = np.concatenate(Ns) if all(n is not None for n in Ns) else None
    UV = np.concatenate(UVs) if all(u is not None for u in UVs) else None
    return P, F, N, UV


def _read_gltf_primitives(path: Path, node: int | None, primitive: int | None, key: str,
                          assets: dict | None = None):
    """Positions, faces, normals, uvs|None, tangents (V, 4)|None of a glTF file's primitives
    in its scene's world space: all of them, or one node's (one primitive of it), concatenated
    (sgpipe.io.gltf; a primitive without tangents has NaN rows when another has some).
    `assets`: files already read, by path (a scene's primitives share their file)."""
    from sgpipe.io.gltf import primitive_geometry, read_gltf
    assets = {} if assets is None else assets
    try:
        if path not in assets:
            assets[path] = read_gltf(path)
        asset = assets[path]
        refs = [r for r in asset.primitives if node is None or (
            r.node == node and (primitive is None or r.primitive == primitive))]
        parts = [primitive_geometry(asset, r) for r in refs]
    except BadInput as e:        # the config key, and the glTF element in the message
        raise BadInput(f"{e.key}: {e.message}" if e.key else e.message, file=e.file,
                       key=key) from None
    if not refs:
        what = "no triangle primitive" if node is None else (
            f"no primitive {primitive} of node {node}" if primitive is not None
            else f"node {node} has no triangle primitive")
        raise BadInput(what, file=path, key=key)
    off = np.cumsum([0] + [len(p["positions"]) for p in parts])[:-1]
    P = np.concatenate([p["positions"] for p in parts])
    F = np.concatenate([p["faces"] + o for p, o in zip(parts, off)])
    N = np.concatenate([p["normals"] for p in parts])
    UV = (np.concatenate([p["uvs"] for p in parts])
          if all(p["uvs"] is not None for p in parts) else None)
    T4 = (np.concatenate([p["tangents"] if p["tangents"] is not None
                          else np.full((len(p["positions"]), 4), np.nan) for p in parts])
          if any(p["tangents"] is not None for p in parts) else None)
    return P, F, N, UV, T4


def object_files(obj) -> list[Path]:
    """The files an object's geometry is read from: its mesh, and a `.gltf`'s buffers."""
    if obj.mesh is None:
        return []
    from sgpipe.io.gltf import companion_files
    return [Path(obj.mesh), *companion_files(obj.mesh)]


def sphere_mesh(radius: float, subdivisions: int):
    """Icosphere (positions, faces, exact normals) of an analytic sphere object."""
    import trimesh
    s = trimesh.creation.icosphere(subdivisions=int(subdivisions), radius=1.0)
    n = np.asarray(s.vertices, float)
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    return n * float(radius), np.asarray(s.faces, np.int64), n


def load_object(obj, index: int = 0, *, sphere_subdivisions: int = 4,
                assets: dict | None = None) -> MeshGeometry:
    """One `scene.objects[i]` entry (ObjectSpec) → world-space MeshGeometry; `assets`: glTF
    files already read by the caller's other objects (filled as they are read)."""
    M = object_matrix(obj.translate, obj.rotate_deg, obj.scale)
    if obj.mesh is not None:
        key = f"scene.objects.{index}.mesh"
        if str(obj.mesh).lower().endswith((".gltf", ".glb")):
            P, F, N, UV, T4 = _read_gltf_primitives(Path(obj.mesh), obj.gltf_node,
                                                    obj.gltf_primitive, key, assets)
        else:
            (P, F, N, UV), T4 = _read_mesh_file(Path(obj.mesh), key), None
        P, N = _transform(M, P, N)   # NaN stays NaN: build_mesh reports it
        if T4 is not None:           # bitangent = w (n × t): a mirroring transform turns w
            T4 = np.column_stack([T4[:, :3] @ M[:3, :3].T,
                                  T4[:, 3] * np.sign(np.linalg.det(M[:3, :3]))])
        return build_mesh(P, F, normals=N, uvs=UV, tangents=T4, name=obj.name,
                          material=obj.material, source=str(obj.mesh), key=key)
    P, F, N = sphere_mesh(obj.sphere_radius, sphere_subdivisions)
    P, N = _transform(M, P, N)
    return build_mesh(P, F, normals=N, name=obj.name, material=obj.material, source=None,
                      key=f"scene.objects.{index}.sphere_radius")


def load_scene(scene, *, sphere_subdivisions: int = 4) -> list[MeshGeometry]:
    """Every object of a SceneSection, in config order."""
    if scene is None or not scene.objects:
        raise BadInput("the scene has no objects", key="scene.objects")
    assets: dict = {}        # a glTF file is read once for all its primitives' objects
    return [load_object(o, i, sphere_subdivisions=sphere_subdivisions, assets=assets)
            for i, o in enumerate(scene.objects)]


def write_obj(path: str | Path, vertices: np.ndarray, faces: np.ndarray, *,
              normals: np.ndarray | None = None, uvs: np.ndarray | None = None,
              header: str = "") -> Path:
    """Write a triangle mesh with per-vertex normals/UVs sharing the vertex index; values rounded
    to 6 decimals without negative zeros, fixed '%.6f' formatting and '\\n' line ends make the
    bytes reproducible on any CPU."""
    from sgpipe.io.atomic import atomic_path

    def rows(a):                       # rounded, −0.0 made +0.0
        return np.round(np.asarray(a, np.float64), 6) + 0.0
    f = np.asarray(faces, np.int64) + 1
    lines = [f"# {line}" for line in header.strip().splitlines()]
    lines.append(f"# vertices {len(vertices)} faces {len(f)}")
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in rows(vertices)]
    if uvs is not None:
        lines += [f"vt {s:.6f} {t:.6f}" for s, t in rows(uvs)]
    if normals is not None:
        lines += [f"vn {x:.6f} {y:.6f} {z:.6f}" for x, y, z in rows(normals)]
    if uvs is not None and normals is not None:
        lines += [f"f {a}/{a}/{a} {b}/{b}/{b} {c}/{c}/{c}" for a, b, c in f]
    elif normals is not None:
        lines += [f"f {a}//{a} {b}//{b} {c}//{c}" for a, b, c in f]
    elif uvs is not None:
        lines += [f"f {a}/{a} {b}/{b} {c}/{c}" for a, b, c in f]
    else:
        lines += [f"f {a} {b} {c}" for a, b, c in f]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        tmp.write_bytes(("\n".join(lines) + "\n").encode("ascii"))
    return path
