"""Texture footprint of primary rays (ray differentials, Igehy 1999; Han07 §7.3 picks the MIP
level from it): per pixel the UV derivatives (du/dx, dv/dx, du/dy, dv/dy) of the hit point when
the camera ray moves by one pixel step in x and in y, and the isotropic MIP level
log2(max footprint in texels).

    duv = uv_derivatives(cam, gb, offset=(0.5, 0.5), step=1.0)   # (H, W, 4) float32
    lod = mip_level(duv, side=256)                                 # (H, W) float

The rays half a step either side are intersected with the tangent plane of the hit
(geometric normal) — the first-order differential, as a central difference — and the plane offsets mapped to UV by the triangle's UV gradient
(meshes) or by the sphere's lat-long mapping (analytic spheres, u wrapped)."""

from __future__ import annotations

import numpy as np


def _plane_offsets(cam, gb, px, py, dx, dy):
    """Offset dp (N, 3) of the rays through (px + dx, py + dy) on each hit's tangent plane."""
    o, d = cam.rays_at(px + dx, py + dy)
    o, d = np.asarray(o, float), np.asarray(d, float)
    p = np.asarray(gb["pos"], float)
    ng = np.asarray(gb["ng"], float)
    den = np.einsum("ij,ij->i", d, ng)
    den = np.where(np.abs(den) > 1e-12, den, 1e-12)
    t = np.einsum("ij,ij->i", p - o, ng) / den
    return o + t[:, None] * d - p


def _mesh_uv_gradient(obj, tri):
    """Per triangle the 2×3 matrix G with duv = G dp for dp in the triangle's plane."""
    f = obj.faces[tri]
    v = obj.vertices[f].astype(float)
    uv = obj.uvs[f].astype(float)
    e1, e2 = v[:, 1] - v[:, 0], v[:, 2] - v[:, 0]
    t1, t2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    # dp = a e1 + b e2 (least squares in the plane): [a b] = Gram⁻¹ [e1·dp, e2·dp]
    g11 = np.einsum("ij,ij->i", e1, e1)
    g12 = np.einsum("ij,ij->i", e1, e2)
    g22 = np.einsum("ij,ij->i", e2, e2)
    det = g11 * g22 - g12 * g12
    det = np.where(np.abs(det) > 1e-30, det, 1e-30)
    # rows of the pseudo-inverse: a = (g22 e1 − g12 e2)·dp / det, b = (g11 e2 − g12 e1)·dp / det
    ra = (g22[:, None] * e1 - g12[:, None] * e2) / det[:, None]
    rb = (g11[:, None] * e2 - g12[:, None] * e1) / det[:, None]
    return t1[:, :, None] * ra[:, None, :] + t2[:, :, None] * rb[:, None, :]   # (N, 2, 3)


def _sphere_uv(obj, p):
    """Lat-long UV of world points projected onto the analytic sphere (gbuffer's mapping)."""
    nl = p - obj.center
    nl = nl / np.maximum(np.linalg.norm(nl, axis=1, keepdims=True), 1e-30)
    local = nl @ obj.rotation
    theta = np.arccos(np.clip(local[:, 1], -1.0, 1.0))
    phi = np.mod(np.arctan2(local[:, 0], -local[:, 2]), 2 * np.pi)
    return np.stack([phi / (2 * np.pi), 1.0 - theta / np.pi], -1)


def uv_derivatives(cam, gb, offset=(0.5, 0.5), step: float = 1.0) -> np.ndarray:
    """(du/dx, dv/dx, du/dy, dv/dy) per pixel (shape S×4, zeros on misses) of the G-buffer `gb`
    traced through sub-pixel position `offset`, for a ray step of `step` pixels (1/N for N×N
    supersampling: each sub-sample's footprint)."""
    shape = gb.hit.shape
    out = np.zeros((int(np.prod(shape)), 4), np.float32)
    idx = np.flatnonzero(gb.hit.reshape(-1))
    if idx.size == 0:
        return out.reshape(shape + (4,))
    rows, cols = np.unravel_index(idx, shape)
    px, py = cols + offset[0], rows + offset[1]
    sel = {"pos": gb.position.reshape(-1, 3)[idx], "ng": gb.geo_normal.reshape(-1, 3)[idx]}
    # central differences (rays ± step/2): second-order accurate, where the one-sided step
    # was off by up to 7 % at oblique views of the analytic sphere (the projective map and the
    # lat-long map curve over one pixel)
    h = 0.5 * step
    dpx = (_plane_offsets(cam, sel, px, py, h, 0.0), _plane_offsets(cam, sel, px, py, -h, 0.0))
    dpy = (_plane_offsets(cam, sel, px, py, 0.0, h), _plane_offsets(cam, sel, px, py, 0.0, -h))
    obj_id = gb.object_id.reshape(-1)[idx]
    tri = gb.triangle_id.reshape(-1)[idx]
    res = np.zeros((len(idx), 4))
    for k, ob in enumerate(gb.objects):
        s = np.flatnonzero(obj_id == k)
        if s.size == 0:
            continue
        if ob.kind == "sphere":
            p = np.asarray(sel["pos"][s], float)
            for c, (dp, dm) in ((0, dpx), (2, dpy)):
                duv = _sphere_uv(ob, p + dp[s]) - _sphere_uv(ob, p + dm[s])
                duv[:, 0] -= np.round(duv[:, 0])      # u wraps at φ = 0
                res[s, c:c + 2] = duv
        elif ob.uvs is not None:
            g = _mesh_uv_gradient(ob, tri[s])
            res[s, 0:2] = np.einsum("nij,nj->ni", g, dpx[0][s] - dpx[1][s])
            res[s, 2:4] = np.einsum("nij,nj->ni", g, dpy[0][s] - dpy[1][s])
    out[idx] = res
    return out.reshape(shape + (4,))


def mip_level(duv: np.ndarray, side: int) -> np.ndarray:
    """Isotropic MIP level log2(max(|∂uv/∂x|, |∂uv/∂y|)·side) (unclamped; −inf-safe: a zero
    footprint gives −60) for a square map of `side` texels."""
    duv = np.asarray(duv, float)
    lx = np.hypot(duv[..., 0], duv[..., 1])
    ly = np.hypot(duv[..., 2], duv[..., 3])
    return np.log2(np.maximum(np.maximum(lx, ly) * side, 1e-18))
