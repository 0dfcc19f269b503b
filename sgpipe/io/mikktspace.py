"""MikkTSpace tangents (Mikkelsen 2008, the algorithm glTF 2.0 prescribes where a primitive with
a normal texture has no TANGENT): per triangle corner a unit tangent and a bitangent sign w,
bitangent = w · (n × t).

    t4 = corner_tangents(positions, normals, uvs, faces)      # (F, 3, 4): xyz, w = ±1
    positions, ..., tangents, faces = split_by_tangent(...)    # per vertex, split where needed

This is the reference implementation's default mode (`genTangSpaceDefault`, angular threshold
180°) written for numpy and numba: vertices are welded where position, normal and UV are equal;
each triangle's ∂p/∂u and ∂p/∂v (oriented by the sign of its UV area) is projected on the
vertex normal; triangles sharing a welded vertex across edges and with the same UV orientation
form a group, whose tangent is the angle-weighted mean of its triangles' projected ∂p/∂u. A
triangle with a degenerate UV map joins the first group that reaches it and adds nothing; a
triangle with coincident corners copies the first healthy corner of its welded vertex.
tests/scene/test_mikktspace.py compares it with outputs of the reference C implementation.
UVs are sgpipe's (v = 0 at the bottom, as Blender's), so w = +1 where increasing v runs along
n × t — the direction a glTF normal texture's +Y (up in the image) points.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_TINY = 1.1754944e-38            # FLT_MIN: the reference's NotZero threshold


def _weld(positions, normals, uvs, faces) -> np.ndarray:
    """(F, 3) welded vertex ids: one id per distinct (position, normal, uv) triple."""
    key = np.ascontiguousarray(np.concatenate([positions, normals, uvs], 1), np.float64)
    _, inv = np.unique(key.view(np.dtype((np.void, key.dtype.itemsize * key.shape[1]))),
                       return_inverse=True)
    return inv.reshape(-1)[faces]


def _neighbours(wid, good):
    """FaceNeighbors: per triangle edge (i, i+1) the triangle across it running the other way
    (the first unpaired one in triangle order), −1 on a border."""
    f = np.repeat(np.flatnonzero(good), 3)
    e = np.tile(np.arange(3), int(good.sum()))
    a, b = wid[f, e], wid[f, (e + 1) % 3]
    keys = np.column_stack([np.minimum(a, b), np.maximum(a, b), f, e]).astype(np.int64)
    keys = keys[np.lexsort((keys[:, 2], keys[:, 1], keys[:, 0]))]
    return _pair_edges(np.ascontiguousarray(wid, np.int64), keys)


@njit(cache=True)
def _pair_edges(wid, keys):
    """Edges sorted by (low vertex, high vertex, triangle) paired with the next unpaired one
    of the same two vertices that runs the other way."""
    nb = np.full((wid.shape[0], 3), -1, np.int64)
    m = keys.shape[0]
    s = 0
    while s < m:
        e = s
        while e < m and keys[e, 0] == keys[s, 0] and keys[e, 1] == keys[s, 1]:
            e += 1
        for i in range(s, e):
            f, ei = keys[i, 2], keys[i, 3]
            if nb[f, ei] != -1:
                continue
            a0, a1 = wid[f, ei], wid[f, (ei + 1) % 3]
            for j in range(i + 1, e):
                t, ej = keys[j, 2], keys[j, 3]
                if nb[t, ej] == -1 and wid[t, ej] == a1 and wid[t, (ej + 1) % 3] == a0:
                    nb[f, ei] = t
                    nb[t, ej] = f
                    break
        s = e
    return nb


@njit(cache=True)
def _unit_or_zero(v):
    ln = np.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return v / ln if (abs(v[0]) > _TINY or abs(v[1]) > _TINY or abs(v[2]) > _TINY) and ln > 0 \
        else v


@njit(cache=True)
def _project(v, n):
    return _unit_or_zero(v - (v[0] * n[0] + v[1] * n[1] + v[2] * n[2]) * n)


@njit(cache=True)
def _corner_of(wid, f, rep):
    for i in range(3):
        if wid[f, i] == rep:
            return i
    return -1


@njit(cache=True)
def _groups(wid, nb, good, orient, anyg):
    """Build4RuleGroups: per corner its group id (−1: none); per group its representative
    welded vertex, orientation and member triangles (in assignment order, as the reference's
    depth-first recursion visits them)."""
    n_tri = wid.shape[0]
    assigned = np.full((n_tri, 3), -1, np.int64)
    g_rep = np.empty(3 * n_tri, np.int64)
    g_orient = np.empty(3 * n_tri, np.bool_)
    g_start = np.zeros(3 * n_tri + 1, np.int64)
    members = np.empty(3 * n_tri, np.int64)
    stack = np.empty(6 * n_tri + 2, np.int64)
    n_g, n_m = 0, 0
    for f in range(n_tri):
        if not good[f] or anyg[f]:
            continue
        for i in range(3):
            if assigned[f, i] != -1:
                continue
            g = n_g
            n_g += 1
            g_rep[g], g_orient[g] = wid[f, i], orient[f]
            g_start[g] = n_m
            assigned[f, i] = g
            members[n_m] = f
            n_m += 1
            top = 0
            for nbr in (nb[f, (i + 2) % 3], nb[f, i]):      # pushed R then L: L first
                if nbr >= 0:
                    stack[top] = nbr
                    top += 1
            while top > 0:
                top -= 1
                t = stack[top]
                j = _corner_of(wid, t, g_rep[g])
                if assigned[t, j] != -1:
                    continue
                if anyg[t] and assigned[t, 0] == -1 and assigned[t, 1] == -1 \
                        and assigned[t, 2] == -1:
                    orient[t] = g_orient[g]  # the first group to reach it sets its orientation
                if orient[t] != g_orient[g]:
                    continue
                assigned[t, j] = g
                members[n_m] = t
                n_m += 1
                for nbr in (nb[t, (j + 2) % 3], nb[t, j]):
                    if nbr >= 0:
                        stack[top] = nbr
                        top += 1
            g_start[g + 1] = n_m
    return assigned, g_rep[:n_g], g_orient[:n_g], g_start[:n_g + 1], members[:n_m]


@njit(cache=True)
def _tspaces(P, N, wid, vidx, vos, vot, anyg, assigned, g_rep, g_orient, g_start, members):
    """GenerateTSpaces + EvalTspace: per corner (F, 3, 4) the tangent and w of its group (the
    subgroup of triangles whose projected ∂p/∂u and ∂p/∂v are not opposite to the corner's
    own: cos > cos 180°), default (1, 0, 0, −1) where no group reaches it."""
    n_tri = wid.shape[0]
    out = np.zeros((n_tri, 3, 4))
    out[:, :, 0] = 1.0
    out[:, :, 3] = -1.0
    for g in range(g_rep.shape[0]):
        a, b = g_start[g], g_start[g + 1]
        rep = g_rep[g]
        for k in range(a, b):
            f = members[k]
            ci = -1
            for i in range(3):
                if assigned[f, i] == g:
                    ci = i
                    break
            n = N[vidx[f, ci]]
            os1, ot1 = _project(vos[f], n), _project(vot[f], n)
            acc = np.zeros(3)
            for kk in range(a, b):
                t = members[kk]
                os2, ot2 = _project(vos[t], n), _project(vot[t], n)
                cs = os1[0] * os2[0] + os1[1] * os2[1] + os1[2] * os2[2]
                ct = ot1[0] * ot2[0] + ot1[1] * ot2[1] + ot1[2] * ot2[2]
                if not (anyg[f] or anyg[t] or f == t or (cs > -1.0 and ct > -1.0)):
                    continue
                if anyg[t]:
                    continue                      # only healthy triangles contribute
                i = _corner_of(wid, t, rep)
                nt = N[vidx[t, i]]
                p1 = P[vidx[t, i]]
                v1 = _project(P[vidx[t, (i + 2) % 3]] - p1, nt)
                v2 = _project(P[vidx[t, (i + 1) % 3]] - p1, nt)
                c = min(1.0, max(-1.0, v1[0] * v2[0] + v1[1] * v2[1] + v1[2] * v2[2]))
                acc += np.arccos(c) * _project(vos[t], nt)
            acc = _unit_or_zero(acc)
            out[f, ci, :3] = acc
            out[f, ci, 3] = 1.0 if g_orient[g] else -1.0
    return out


def corner_tangents(positions, normals, uvs, faces) -> np.ndarray:
    """MikkTSpace per triangle corner: (F, 3, 4) unit tangent xyz and bitangent sign w.
    `normals` unit (V, 3), `uvs` (V, 2) in sgpipe's convention (v = 0 at the bottom)."""
    P = np.asarray(positions, np.float64).reshape(-1, 3)
    N = np.asarray(normals, np.float64).reshape(-1, 3)
    UV = np.asarray(uvs, np.float64).reshape(-1, 2)
    F = np.asarray(faces, np.int64).reshape(-1, 3)
    wid = _weld(P, N, UV, F)
    p, t = P[F], UV[F]
    good = ~((p[:, 0] == p[:, 1]).all(1) | (p[:, 0] == p[:, 2]).all(1)
             | (p[:, 1] == p[:, 2]).all(1))
    d1, d2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    t21, t31 = t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]
    area = t21[:, 0] * t31[:, 1] - t21[:, 1] * t31[:, 0]
    vos = t31[:, 1:2] * d1 - t21[:, 1:2] * d2                 # ∂p/∂u × twice the UV area
    vot = -t31[:, 0:1] * d1 + t21[:, 0:1] * d2                 # ∂p/∂v × twice the UV area
    orient = area > 0
    sign = np.where(orient, 1.0, -1.0)
    ls, lt = np.linalg.norm(vos, axis=1), np.linalg.norm(vot, axis=1)
    nz = np.abs(area) > _TINY
    with np.errstate(divide="ignore", invalid="ignore"):
        vos = np.where((nz & (ls > _TINY))[:, None], vos * (sign / ls)[:, None], 0.0)
        vot = np.where((nz & (lt > _TINY))[:, None], vot * (sign / lt)[:, None], 0.0)
        mags, magt = ls / np.abs(area), lt / np.abs(area)
    anyg = ~(nz & (mags > _TINY) & (magt > _TINY))
    nb = _neighbours(wid, good)
    groups = _groups(wid, nb, good, orient.copy(), anyg)
    out = _tspaces(P, N, wid, F, vos, vot, anyg, *groups)
    bad = np.flatnonzero(~good)
    if bad.size:                 # coincident corners: the first healthy corner of the vertex
        flat = wid[good].ravel()
        src = out[good].reshape(-1, 4)
        first = {}
        for k in range(len(flat) - 1, -1, -1):
            first[int(flat[k])] = k
        for f in bad:
            for i in range(3):
                k = first.get(int(wid[f, i]))
                if k is not None:
                    out[f, i] = src[k]
    return out


def split_by_tangent(faces, corner_t4) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-vertex tangents from per-corner ones: (source vertex per output vertex (V',),
    tangents (V', 4), faces (F, 3)); a vertex whose corners got different tangents is split,
    one copy per distinct tangent."""
    F = np.asarray(faces, np.int64).reshape(-1, 3)
    t4 = np.asarray(corner_t4, np.float64).reshape(-1, 4)
    key = np.column_stack([F.reshape(-1).astype(np.float64), t4])
    uniq, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    order = np.argsort(first, kind="stable")             # vertices in first-corner order
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    return (uniq[order, 0].astype(np.int64), uniq[order, 1:],
            rank[inv.reshape(-1)].reshape(-1, 3))


def gltf_primitive_tangents(pos, nrm, uv, faces):
    """A glTF primitive (mesh space, glTF UVs with v = 0 at the top) completed with MikkTSpace
    tangents: (positions, normals, uvs, tangents (V', 4), faces), vertices split where their
    corners' tangents differ. The UVs are turned to sgpipe's (v = 0 at the bottom) for the
    computation, so w = +1 where the texture's +Y (up in the image) runs along n × t."""
    ln = np.linalg.norm(nrm, axis=1, keepdims=True)
    unit = np.where(ln > 0, nrm / np.where(ln > 0, ln, 1.0), 0.0)
    up = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]])
    src, tan, faces = split_by_tangent(faces, corner_tangents(pos, unit, up, faces))
    return pos[src], nrm[src], uv[src], tan, faces
