"""Sample meshes for data_samples/: UV sphere, tessellated Utah teapot, floor plane; plain OBJ writer.

Conventions (docs/CONVENTIONS.md): +Y up, counter-clockwise faces seen from outside (outward geometric
normal = (b - a) x (c - a)), vertex normals unit length and outward. OBJ `vt` uses the usual
v-up convention (v = 0 is the bottom row of an image).
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

import teapot_data
from canonical import cross3, norm3, normalize3

# ---------------------------------------------------------------- OBJ writer


def write_obj(path: str | os.PathLike, vertices: np.ndarray, faces: np.ndarray, *,
              normals: np.ndarray | None = None, uvs: np.ndarray | None = None,
              header: str = "") -> Path:
    """sgpipe.io.mesh.write_obj (reproducible bytes on any CPU)."""
    from sgpipe.io.mesh import write_obj as _write
    return _write(path, vertices, faces, normals=normals, uvs=uvs, header=header)


# ---------------------------------------------------------------- sphere


def uv_sphere(n_phi: int = 72, n_theta: int = 36):
    """Unit UV sphere in the lat-long convention: vertex at (theta, phi) is
    (sin t sin p, cos t, -sin t cos p) with vt = (phi / 2pi, 1 - theta / pi), so a lat-long
    texture shows direction d at the surface point d. One vertex per pole triangle (the pole
    vertices carry the UV of their triangle's middle), a duplicated seam column at phi = 2pi."""
    verts, uvs, faces = [], [], []
    top = []
    for i in range(n_phi):  # north pole copies
        top.append(len(verts))
        verts.append((0.0, 1.0, 0.0))
        uvs.append(((i + 0.5) / n_phi, 1.0))
    rings = []
    for j in range(1, n_theta):
        theta = np.pi * j / n_theta
        row = []
        for i in range(n_phi + 1):
            phi = 2.0 * np.pi * i / n_phi
            row.append(len(verts))
            verts.append((np.sin(theta) * np.sin(phi), np.cos(theta),
                          -np.sin(theta) * np.cos(phi)))
            uvs.append((i / n_phi, 1.0 - j / n_theta))
        rings.append(row)
    bottom = []
    for i in range(n_phi):
        bottom.append(len(verts))
        verts.append((0.0, -1.0, 0.0))
        uvs.append(((i + 0.5) / n_phi, 0.0))
    # phi grows clockwise seen from +Y, so CCW-from-outside order is (pole, ring[i+1], ring[i]).
    for i in range(n_phi):
        faces.append((top[i], rings[0][i + 1], rings[0][i]))
    for j in range(n_theta - 2):
        a, b = rings[j], rings[j + 1]
        for i in range(n_phi):
            faces.append((a[i], a[i + 1], b[i + 1]))
            faces.append((a[i], b[i + 1], b[i]))
    for i in range(n_phi):
        faces.append((bottom[i], rings[-1][i], rings[-1][i + 1]))
    v = np.array(verts)
    return v, np.array(faces), v.copy(), np.array(uvs)


# ---------------------------------------------------------------- floor


def floor_plane(size: float = 6.0, n: int = 100):
    """Square at y = 0, x and z in [-size/2, size/2], n x n quads, normal +Y.
    vt = ((x + s/2) / s, (s/2 - z) / s): dP/du = +X = tangent, dP/dv = -Z = n x t."""
    c = (np.arange(n + 1) / n - 0.5) * size
    x, z = np.meshgrid(c, c[::-1], indexing="xy")  # row 0 at +z ... last row at -z
    verts = np.stack([x, np.zeros_like(x), z], -1).reshape(-1, 3)
    uvs = np.stack([(x + size / 2) / size, (size / 2 - z) / size], -1).reshape(-1, 2)
    idx = np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()  # row r (larger z)
    d, e = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()    # row r+1 (smaller z)
    # (a, b, e): b - a = +x, e - a = +x - z -> cross is +Y.
    faces = np.concatenate([np.stack([a, b, e], 1), np.stack([a, e, d], 1)]).reshape(-1, 3)
    normals = np.tile([0.0, 1.0, 0.0], (len(verts), 1))
    return verts, faces, normals, uvs


# ---------------------------------------------------------------- teapot


def _bernstein(t: np.ndarray):
    """Cubic Bernstein basis and derivative, shape (len(t), 4)."""
    s = 1.0 - t
    b = np.stack([s ** 3, 3 * s * s * t, 3 * s * t * t, t ** 3], -1)
    db = np.stack([-3 * s * s, 3 * s * s - 6 * s * t, 6 * s * t - 3 * t * t, 3 * t * t], -1)
    return b, db


def _eval_patch(net: np.ndarray, t: np.ndarray):
    """Bicubic Bezier patch on the grid t x t: points, dP/du, dP/dv, each (n, n, 3)."""
    b, db = _bernstein(t)

    def tensor(bu, bv):
        # Σ_i Σ_j bu[u, i] bv[v, j] net[i, j] term by term (einsum's order depends on the CPU).
        out = np.zeros((len(t), len(t), 3))
        for i in range(4):
            for j in range(4):
                out = out + (bu[:, i, None] * bv[None, :, j])[..., None] * net[i, j]
        return out
    return tensor(b, b), tensor(db, b), tensor(b, db)


def _patch_normals(net: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Outward unit normals, P_v x P_u (Newell's patches all have P_u x P_v pointing inward).
    Where that vanishes (collapsed pole rows of the lid knob and the bottom) take the limit
    from a point a little way into the patch; the pole copies are averaged after welding."""
    _, pu, pv = _eval_patch(net, t)
    n = cross3(pv, pu)
    length = norm3(n)
    bad = length < 1e-9 * max(1.0, float(length.max()))
    if bad.any():
        eps = 1e-4
        shifted = np.where(t < 0.5, t + eps, t - eps)
        _, pu2, pv2 = _eval_patch(net, shifted)
        n2 = cross3(pv2, pu2)
        n = np.where(bad[..., None], n2, n)
    return normalize3(n)


def teapot(n: int = 18, *, quantum: float = 1e-7):
    """Utah teapot from Newell's 32 Bezier patches: n x n quads per patch, vertices welded along
    seams (positions equal to `quantum`, in Newell units), smooth normals averaged over the
    welded copies and snapped to -+Y on the axis poles, then rotated Z-up -> Y-up, centred in
    x/z, bottom at y = 0 and scaled to fit the unit sphere about (0, height/2, 0).
    Returns (vertices, faces, normals, info)."""
    pts = np.asarray(teapot_data.POINTS, np.float64)
    nets = pts[np.asarray(teapot_data.PATCHES) - 1].reshape(32, 4, 4, 3)
    t = np.linspace(0.0, 1.0, n + 1)
    all_p, all_n, all_f = [], [], []
    for k in range(32):
        p, _, _ = _eval_patch(nets[k], t)
        all_p.append(p.reshape(-1, 3))
        all_n.append(_patch_normals(nets[k], t).reshape(-1, 3))
        idx = k * (n + 1) ** 2 + np.arange((n + 1) ** 2).reshape(n + 1, n + 1)
        a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
        c, d = idx[1:, 1:].ravel(), idx[1:, :-1].ravel()
        # outward is P_v x P_u, i.e. CCW order (0,0) -> (0,1) -> (1,1) in (u, v) indices.
        all_f.append(np.stack([a, b, c], 1))
        all_f.append(np.stack([a, c, d], 1))
    p = np.concatenate(all_p)
    nrm = np.concatenate(all_n)
    f = np.concatenate(all_f)
    # Weld identical positions (seams share control points, so they agree to rounding) within
    # each part: the handle's lower end touches the body at one control point, keep it apart.
    part = np.zeros(32, np.int64)
    part[list(teapot_data.PATCH_GROUPS["lid"])] = 1
    part[list(teapot_data.PATCH_GROUPS["handle"])] = 2
    part[list(teapot_data.PATCH_GROUPS["spout"])] = 3
    part = np.repeat(part, (n + 1) ** 2)[:, None]
    key = np.concatenate([part, np.round(p / quantum).astype(np.int64)], axis=1)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first)              # keep first-appearance order (deterministic, local)
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    inverse = rank[inverse.ravel()]
    verts = p[first[order]]
    acc = np.zeros_like(verts)
    np.add.at(acc, inverse, nrm)
    faces = inverse[f]
    faces = faces[(faces[:, 0] != faces[:, 1]) & (faces[:, 1] != faces[:, 2])
                  & (faces[:, 0] != faces[:, 2])]
    normals = normalize3(acc)
    on_axis = np.hypot(verts[:, 0], verts[:, 1]) < 1e-9
    normals[on_axis] = np.array([0.0, 0.0, 1.0]) * np.sign(normals[on_axis, 2:3])
    # Newell Z-up -> Y-up: rotation by -90 degrees about X, (x, y, z) -> (x, z, -y).
    # A permutation with one sign flip, applied exactly (a matmul's rounding and the sign of
    # its zeros depend on the BLAS kernel).
    def z_up_to_y_up(a):
        return np.stack([a[:, 0], a[:, 2], -a[:, 1]], -1)
    verts, normals = z_up_to_y_up(verts), z_up_to_y_up(normals)
    lo, hi = verts.min(0), verts.max(0)
    centre = np.array([(lo[0] + hi[0]) / 2, lo[1], (lo[2] + hi[2]) / 2])
    verts = verts - centre
    height = verts[:, 1].max()
    scale = 1.0 / norm3(verts - [0.0, height / 2, 0.0]).max()
    verts = verts * scale
    # Newell's frame of the offset: (x, y, z) -> (x, -z, y) undoes the rotation above.
    offset = [float(centre[0]), float(-centre[2]) + 0.0, float(centre[1])]
    info = {"patch_grid": n, "newell_offset": offset, "scale": float(scale)}
    return verts, faces, normals, info
