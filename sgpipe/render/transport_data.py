"""Device buffers of the `transport` method (Green06 §5): per object its fitted Gaussians
(gaussians.npz through `sgpipe.artifacts.transport`'s decoders), SH transfer vectors and
diffuse f_d from `<out>/transport/<object>/`, the environment's SH light coefficients
(`<out>/envmap/light_sh.npz`, turned by render.environment_rotation: `rotate_sh`) and the
92-view tables of `views.nearest_views`, keyed by the kernel's parameter names
(`methods.TRANSPORT_PARAMS`, layouts in kernels/include/transport.h)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput

#: Gaussians per vertex and view the kernel blends (transport.h TP_MAX_K)
MAX_GAUSSIANS = 4
#: SH coefficients per transfer vector (5th order, sgpipe.transport.sh_transfer)
SH_COEFFS = 25


def view_tables() -> tuple[np.ndarray, np.ndarray]:
    """(vinv (F·3, 4) float32: per triangle of the 92 views' convex hull the rows of M⁻¹,
    M = [a b c] its views as columns; vtri (F, 4) int32: its view indices), from
    `core.sphere.icosahedral_view_set` (what sgpipe.transport.views.nearest_views walks)."""
    from sgpipe.core.sphere import icosahedral_view_set
    dirs, tri, _, _ = icosahedral_view_set(3)
    M = np.stack([dirs[tri[:, 0]], dirs[tri[:, 1]], dirs[tri[:, 2]]], axis=-1)
    vinv = np.zeros((len(tri), 3, 4), np.float32)
    vinv[..., :3] = np.linalg.inv(M)                        # (F, 3, 3)
    vtri = np.zeros((len(tri), 4), np.int32)
    vtri[:, :3] = tri
    return vinv.reshape(-1, 4), vtri


def sh_rotation_matrix(R, lmax: int) -> np.ndarray:
    """((lmax+1)², (lmax+1)²) matrix D with D·c the SH coefficients of f(Rᵀω) when c are those
    of f(ω) (core.sh basis): D_kj = ∫ Y_k(ω) Y_j(Rᵀω) dω by a product rule exact for the degree
    ≤ 2·lmax integrand (Gauss–Legendre in cos θ × uniform φ), so the rotation is exact to
    rounding — the numerical route to the Wigner D-matrices (block-diagonal per band)."""
    from sgpipe.core.sh import sh_eval
    x, wx = np.polynomial.legendre.leggauss(lmax + 2)              # exact to degree 2lmax+3
    nphi = 2 * lmax + 3                                             # trig degree ≤ 2lmax + 2
    phi = 2.0 * np.pi * np.arange(nphi) / nphi
    st = np.sqrt(1.0 - x * x)
    d = np.stack([st[:, None] * np.cos(phi), st[:, None] * np.sin(phi),
                  np.broadcast_to(x[:, None], (len(x), nphi))], -1).reshape(-1, 3)
    w = np.repeat(wx * (2.0 * np.pi / nphi), nphi)
    R = np.asarray(R, np.float64)
    D = (sh_eval(d, lmax) * w[:, None]).T @ sh_eval(d @ R, lmax)   # rows of d @ R: Rᵀd
    band = np.repeat(np.arange(lmax + 1), 2 * np.arange(lmax + 1) + 1)
    return np.where(band[:, None] == band[None, :], D, 0.0)        # other bands: rounding only


def rotate_sh(coeffs, R) -> np.ndarray:
    """SH coefficients ((lmax+1)², C) of the environment turned by R (world ← map): f(Rᵀω);
    R None: unchanged."""
    c = np.asarray(coeffs, np.float64)
    if R is None or len(c) == 0:
        return c
    lmax = int(round(np.sqrt(len(c)))) - 1
    if (lmax + 1) ** 2 != len(c):
        raise ValueError(f"{len(c)} SH coefficients is not a full set of bands")
    return np.tensordot(sh_rotation_matrix(R, lmax), c, axes=(1, 0))


def pack_gaussians(mu, sigma, w) -> np.ndarray:
    """mu (X, 92, K, 3), sigma (X, 92, K), w (X, 92, K, 3) → (X·92·K·2, 4) float32 records
    (μ.xyz, σ), (w.rgb, 0) at ((x·92 + view)·K + k)·2."""
    X, V, K = sigma.shape
    rec = np.zeros((X, V, K, 2, 4), np.float32)
    rec[..., 0, :3] = mu
    rec[..., 0, 3] = sigma
    rec[..., 1, :3] = w
    return rec.reshape(-1, 4)


def rgb_transfer(transfer) -> np.ndarray:
    """(X, 25, 3) float32 transfer: an RGB transfer as it is, a grey (X, 25) one per channel."""
    t = np.asarray(transfer, np.float32)
    if t.ndim == 2:
        t = np.repeat(t[..., None], 3, axis=-1)
    if t.ndim != 3 or t.shape[1:] != (SH_COEFFS, 3):
        raise ValueError(f"SH transfer of shape {t.shape}: expected (X, {SH_COEFFS}[, 3])")
    return t


#: point-set members within this angle of a brighter one merge into its small light
MERGE_POINTS_DEG = 4.0
#: the merged lights' sharpness range: a single point is a delta light to the SSDF horizon
MAX_POINT_LAMBDA = 2.0e4


def merge_points(dirs, energy, *, within_deg: float = MERGE_POINTS_DEG) -> np.ndarray:
    """The point set (unit directions (K, 3), energies (K, 3)) as few small SG lights for the
    diffuse sum: greedy from the brightest, every point within `within_deg` of the seed joins
    it; a light's direction is the energy-weighted mean, its energy the sum, its sharpness
    λ = 2/⟨ψ²⟩ from the members' energy-weighted squared angles ψ to it (an SG's ⟨ψ²⟩ is
    2/λ), capped at MAX_POINT_LAMBDA. (M, 2, 4) float32 records (c, λ), (E, 0)."""
    d = np.asarray(dirs, np.float64).reshape(-1, 3)
    e = np.asarray(energy, np.float64).reshape(-1, 3)
    w = e.mean(axis=1)
    free = np.ones(len(d), bool)
    cos_in = np.cos(np.radians(within_deg))
    out = []
    for seed in np.argsort(-w, kind="stable"):
        if not free[seed]:
            continue
        mem = free & (d @ d[seed] >= cos_in)
        free &= ~mem
        c = (w[mem, None] * d[mem]).sum(0)
        c = c / np.linalg.norm(c) if np.linalg.norm(c) > 0 else d[seed]
        psi2 = np.arccos(np.clip(d[mem] @ c, -1.0, 1.0)) ** 2
        mean_psi2 = (w[mem] * psi2).sum() / max(w[mem].sum(), 1e-30)
        lam = MAX_POINT_LAMBDA if mean_psi2 <= 2.0 / MAX_POINT_LAMBDA else 2.0 / mean_psi2
        out.append([[*c, lam], [*e[mem].sum(0), 0.0]])
    return np.asarray(out, np.float32).reshape(-1, 2, 4)


def transport_arrays(objects: list, light_sh: np.ndarray, rotation=None,
                     points=None) -> dict:
    """Kernel arrays for per-object data `objects` (None, or dict with mu, sigma, w, transfer
    (X, 25, 3) per colour channel — or (X, 25), the same in every channel —, optionally
    indirect (X, 25, 3), the interreflected part of transfer, open (the unshadowed mu, sigma,
    w: tp_gauss_open, flag 4 of tp_obj.w), diffuse_rgb (3,), faces (F, 3))
    and SH light coefficients (n, 3) of the map, turned by `rotation` (3×3 world ← map, or
    None). `points`: the environment's point set (directions (K, 3) in the map's frame,
    energies (K, 3)) that objects with SSDF visibility shade as small lights (merge_points,
    tp_suns, turned to world): tp_light_sh holds the whole map's coefficients, the map's minus
    the points' (Σ_k E_k Y(c_k)), and the points'. tp_sh and tp_sh_ind are (X·25·3) floats,
    vertex-major, then coefficient, then RGB (the kernel's vload3 per coefficient)."""
    light_sh = np.asarray(light_sh, np.float64).reshape(-1, 3)
    pts_sh = np.zeros_like(light_sh)
    suns, n_suns = np.zeros((1, 2, 4), np.float32), 0
    if points is not None and len(points[0]):
        if len(light_sh):
            from sgpipe.core.sh import sh_eval
            lmax = int(round(np.sqrt(len(light_sh)))) - 1
            pts_sh = (sh_eval(np.asarray(points[0], np.float64), lmax).T
                      @ np.asarray(points[1], np.float64))
        suns = merge_points(*points)
        n_suns = len(suns)
        if rotation is not None:
            suns[:, 0, :3] = suns[:, 0, :3] @ np.asarray(rotation, np.float32).T
    light_sh, pts_sh = rotate_sh(light_sh, rotation), rotate_sh(pts_sh, rotation)
    rows, faces, gauss, gopen, sh, ind, fd = [], [], [], [], [], [], []
    v0 = f0 = 0
    K = max([o["sigma"].shape[2] for o in objects if o is not None] or [1])
    for o in objects:
        if o is None:
            rows.append((0, 0, 0, 0))
            fd.append(np.zeros(4, np.float32))
            continue
        X = len(o["transfer"])
        k = o["sigma"].shape[2]
        mu, sigma, w = o["mu"], o["sigma"], o["w"]
        op = o.get("open")             # (mu, sigma, w) unshadowed, or None (sampling: cube)
        if op is None:
            op = (np.zeros_like(mu), np.zeros_like(sigma), np.zeros_like(w))
        pad = lambda a: np.concatenate([a, np.zeros(a.shape[:2] + (K - k,) + a.shape[3:])], 2)
        if k < K:      # pad to the scene's K with zero-weight Gaussians (skipped by the kernel)
            mu, sigma, w = pad(mu), pad(sigma), pad(w)
            op = tuple(pad(a) for a in op)
        has_ind = o.get("indirect") is not None
        flags = 1 | (2 if has_ind else 0) | (4 if o.get("open") is not None else 0)
        rows.append((v0, f0, K, flags))             # transport_shade.cl TP_HAS_*
        faces.append(np.asarray(o["faces"], np.int32).reshape(-1))
        gauss.append(pack_gaussians(mu, sigma, w))
        gopen.append(pack_gaussians(*op))
        sh.append(rgb_transfer(o["transfer"]).reshape(-1))
        ind.append(rgb_transfer(o["indirect"] if has_ind else np.zeros((X, SH_COEFFS),
                                                                       np.float32)).reshape(-1))
        fd.append(np.append(np.asarray(o["diffuse_rgb"], np.float32), 0.0))
        v0 += X
        f0 += len(o["faces"])
    if K > MAX_GAUSSIANS:
        raise BadInput(f"{K} Gaussians per view; the transport method blends at most "
                       f"{MAX_GAUSSIANS}", key="transport.gaussians")
    cat = lambda parts, dt, w=1: (np.concatenate(parts).astype(dt) if parts
                                  else np.zeros((1, w) if w > 1 else 1, dt))
    L = np.zeros((3, SH_COEFFS, 4), np.float32)       # whole map, map − points, points
    n_sh = min(len(light_sh), SH_COEFFS)
    for i, c in enumerate((light_sh, light_sh - pts_sh, pts_sh)):
        L[i, :n_sh, :3] = c[:n_sh]
    vinv, vtri = view_tables()
    return dict(tp_obj=np.asarray(rows, np.int32), tp_faces=cat(faces, np.int32),
                tp_gauss=cat(gauss, np.float32, 4), tp_gauss_open=cat(gopen, np.float32, 4),
                tp_sh=cat(sh, np.float32),
                tp_sh_ind=cat(ind, np.float32), tp_fd=np.asarray(fd, np.float32),
                tp_light_sh=L.reshape(-1, 4), tp_sh_n=n_sh, tp_suns=suns.reshape(-1, 4),
                tp_n_suns=n_suns,
                tp_vinv=vinv, tp_vtri=vtri)


def load_transport_objects(cfg, out_dir: str | Path, ssdf_faces: list) -> list:
    """Per scene object its transport data (dicts of `transport_arrays`) read from
    `<out>/transport/`. The kernel indexes them with the frame's SSDF-mesh triangles, so each
    object's transport mesh must be its visibility mesh (`ssdf_faces`, per object or None)."""
    from sgpipe.artifacts.transport import (GEOMETRY, decode_gaussians, decode_open_gaussians,
                                            object_file, read_packed_gaussians,
                                            read_sh_transfer_parts)
    from sgpipe.io import read_npz
    folder = Path(out_dir) / "transport"
    if cfg.transport is None or not (folder / "manifest.json").is_file():
        raise BadInput("the transport method needs the transport stage's artifacts (a "
                       "`transport:` section and `sgpipe precompute`)", file=folder,
                       key="transport")
    out = []
    for k, spec in enumerate(cfg.scene.objects):
        packed = read_packed_gaussians(folder, spec.name)
        shadowed = decode_gaussians(packed)
        mu, sigma, w, _ = shadowed
        opened = decode_open_gaussians(packed, shadowed)
        transfer, indirect, fd = read_sh_transfer_parts(folder, spec.name)
        faces = read_npz(folder / object_file(spec.name, GEOMETRY))["faces"]
        ref = ssdf_faces[k]
        if ref is None or np.shape(ref) != np.shape(faces) or not np.array_equal(ref, faces):
            raise BadInput("the transport mesh differs from the visibility mesh the frame's "
                           "triangles index (set transport.sphere_subdivisions = "
                           "visibility.sphere_subdivisions; the transport method needs a "
                           "`visibility:` section)", file=folder / spec.name,
                           key="transport.sphere_subdivisions")
        out.append(dict(mu=mu, sigma=sigma, w=w, transfer=transfer, diffuse_rgb=fd, faces=faces,
                        indirect=indirect, open=None if opened is None else opened[:3]))
    return out


def attach_transport(renderer, cfg, out_dir: str | Path, vis_objects: list) -> None:
    """Upload the transport method's arrays into `renderer.static` (by parameter name), the SH
    light turned by the config's render.environment_rotation (as the render stage turns the
    renderer's environment: Renderer.rotate_environment)."""
    from sgpipe.artifacts.envmap import read_light_sh
    env_dir = Path(out_dir) / "envmap"
    light = (np.zeros((SH_COEFFS, 3)) if cfg.envmap is None
             else np.asarray(read_light_sh(env_dir)["coeffs"], np.float64))
    objs = load_transport_objects(cfg, out_dir, [None if v is None else v.faces
                                                 for v in vis_objects])
    rot = cfg.render.environment_rotation.matrix() if cfg.render is not None else None
    env = renderer.env        # its point set, in the map's frame (turned like the SH)
    upload_transport(renderer, transport_arrays(objs, light, rot,
                                                (env.point_dirs, env.point_energy)))


def upload_transport(renderer, arrays: dict) -> None:
    """Put `transport_arrays`' output on the renderer's device, into `renderer.static`."""
    from sgpipe.render import opencl
    dev = {k: opencl.to_device(renderer.ctx, a, dtype=a.dtype) if isinstance(a, np.ndarray)
           else a for k, a in arrays.items()}
    renderer.static.update(dev)


__all__ = ["MAX_GAUSSIANS", "merge_points", "view_tables", "sh_rotation_matrix", "rotate_sh",
           "pack_gaussians", "rgb_transfer", "transport_arrays", "load_transport_objects",
           "attach_transport", "upload_transport"]
