"""Where a hemisphere's visibility can change: the projected contour and open edges of a mesh.

Seen from a point o, the set of occluded directions is the union of the triangles'
projections; its boundary lies on the projections of the edges where it can end: open and
non-manifold edges, and contour edges (one adjacent face turned towards o, the other away).
An edge between two faces turned the same way is covered on both sides, so visibility
cannot change across it. Hence two neighbouring trace texels whose connecting great-circle
arc crosses no projected contour or open edge have the same visibility, and so has every
4-connected region of texels away from those edges: one ray decides it (the adaptive sampler
in trace.py traces three). `silhouette_mark` samples every projected edge at steps of
at most about one texel and marks the texels within `pad` = 1.5 texels (Chebyshev, on the
concentric square) of each sample: both texels of every crossed pair are then marked, which
needs pad ≥ 1 + (the bend of a one-texel arc on the square + half a step); brute force over
random arcs at 32²–512² finds 1.1 enough (tests/visibility/test_silhouette.py). This is
exact geometry; Embree's ray–triangle tests are not watertight in every case, so a ray of
the full trace can slip through a shared edge where the adaptive image has the occluder.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from sgpipe.visibility import _silhouette_jit
from sgpipe.visibility.hemigrid import texel_dirs

#: marking half-width in trace texels: one texel to the pair's far centre + the slack below ½
PAD = 1.5


@dataclass(frozen=True)
class EdgeTable:
    """Edges of a triangle soup welded by position: ends p0/p1 (E, 3), adjacent faces fa/fb
    (fb −1 open, −2 non-manifold), flip (E,) −1 where both faces wind the edge the same way,
    unit face normals fn (F, 3; 0 when degenerate), plane offsets fd = fn · corner (F,), and
    the soup's bounding-box diagonal."""

    p0: np.ndarray
    p1: np.ndarray
    fa: np.ndarray
    fb: np.ndarray
    flip: np.ndarray
    fn: np.ndarray
    fd: np.ndarray
    diagonal: float


def edge_table(triangles: np.ndarray) -> EdgeTable:
    """The EdgeTable of (F, 3, 3) triangle corners (exactly equal corners are one vertex)."""
    tri = np.asarray(triangles, np.float64).reshape(-1, 3, 3)
    nf = len(tri)
    pos, vid = np.unique(tri.reshape(-1, 3), axis=0, return_inverse=True)
    vid = vid.reshape(nf, 3)
    u = vid.ravel()
    v = vid[:, [1, 2, 0]].ravel()
    face = np.repeat(np.arange(nf), 3)
    keep = u != v                                       # edges of zero length project to points
    u, v, face = u[keep], v[keep], face[keep]
    lo, hi = np.minimum(u, v), np.maximum(u, v)
    fwd = u < v
    order = np.lexsort((face, hi, lo))
    lo, hi, fwd, face = lo[order], hi[order], fwd[order], face[order]
    new = np.ones(len(lo), bool)
    new[1:] = (lo[1:] != lo[:-1]) | (hi[1:] != hi[:-1])
    first = np.flatnonzero(new)
    count = np.diff(np.append(first, len(lo)))
    fa = face[first]
    fb = np.where(count == 1, -1, np.where(count == 2, face[np.minimum(first + 1, len(lo) - 1)],
                                            -2))
    same = fwd[first] == fwd[np.minimum(first + 1, len(lo) - 1)]
    flip = np.where((count == 2) & same, -1.0, 1.0)
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    ln = np.linalg.norm(fn, axis=1, keepdims=True)
    fn = np.where(ln > 0.0, fn / np.where(ln > 0.0, ln, 1.0), 0.0)
    fd = np.einsum("ij,ij->i", fn, tri[:, 0])
    diag = float(np.linalg.norm(np.ptp(pos, axis=0))) if len(pos) else 0.0
    c = np.ascontiguousarray
    return EdgeTable(c(pos[lo[first]]), c(pos[hi[first]]), c(fa.astype(np.int64)),
                     c(fb.astype(np.int64)), c(flip), c(fn), c(fd), diag)


@lru_cache(maxsize=8)
def arc_step(trace_res: int) -> float:
    """Angular step of the edge sampling: the smallest angle between 4-neighbouring trace
    texels (a step moves at most about one texel anywhere on the image)."""
    d = texel_dirs(trace_res)
    a = np.sum(d[:, 1:] * d[:, :-1], axis=-1).max()
    b = np.sum(d[1:] * d[:-1], axis=-1).max()
    return float(np.arccos(np.clip(max(a, b), -1.0, 1.0)))


def silhouette_mark(edges: EdgeTable, origin, tangent, bitangent, normal, trace_res: int,
                    pad: float = PAD) -> np.ndarray | None:
    """(T, T) bool: the trace texels a visibility boundary can touch, for rays from `origin`
    in the frame (t, b, n); None when no bound holds (an edge through the origin, or a
    singular frame) and every texel must be traced."""
    m = np.stack([np.asarray(tangent, np.float64), np.asarray(bitangent, np.float64),
                  np.asarray(normal, np.float64)], axis=1)
    if abs(np.linalg.det(m)) < 1e-12:
        return None
    tol = 1e-6 * max(edges.diagonal, 1e-30)
    mark, everything = _silhouette_jit.silhouette_mark(
        edges.p0, edges.p1, edges.fa, edges.fb, edges.flip, edges.fn, edges.fd,
        np.asarray(origin, np.float64), np.linalg.inv(m), tol, int(trace_res),
        arc_step(int(trace_res)), float(pad))
    return None if everything else mark


__all__ = ["EdgeTable", "edge_table", "arc_step", "silhouette_mark", "PAD"]
