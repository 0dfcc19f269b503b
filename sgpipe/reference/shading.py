"""Per-tile estimator of the `reference` method (contract: sgpipe.reference): material / light
normalisation and the MIS estimator over one tile of hit pixels; with `bounces` > 0 the paths
go on through up to that many further surfaces (`_shade_paths`: interreflection, the rendering
equation's Neumann series cut after N indirect bounces). `shade_tile` is the module-level
function mapped over tiles by map_chunks."""

from __future__ import annotations

import pickle

import numpy as np

from sgpipe.reference import _sampling_jit as jit
from sgpipe.reference.lights import light_samples
from sgpipe.reference.sampler import EnvSampler

_ROWS_PER_PASS = 1 << 16  # sample rows per numpy batch inside a tile
_LIGHT_STREAM = 0x11647A4EA  # seed tweak of the area lights' uniforms
_BOUNCE_STREAM = 0x2B0C3E5D7  # seed tweak of the indirect bounces' uniforms
_TNEAR = 1e-5                 # start of shadow and continuation rays past the offset origin


# --- materials and lights -------------------------------------------------------------------
def _material_key(m):
    """Picklable description of a material: a BRDF object, or (model, params)."""
    if hasattr(m, "eval") and hasattr(m, "sample") and hasattr(m, "pdf"):
        return m
    if isinstance(m, (tuple, list)) and len(m) == 2:
        return (str(m[0]), dict(m[1] or {}))
    if isinstance(m, dict):
        return (str(m["model"]), dict(m.get("params") or {}))
    raise TypeError(f"cannot make a BRDF from {m!r}")


def _make_brdf(key):
    if not isinstance(key, tuple):
        return key
    from sgpipe.brdf import make_brdf
    return make_brdf(key[0], key[1])


# --- the per-tile estimator -----------------------------------------------------------------
def _brdf_eval(brdf, o, i, scale=None):
    """ρ(o, i) as (N, 3); `scale` = (kd multiplier (N,3), ks multiplier (N,3)) for textures."""
    if scale is not None:
        return (scale[0] * np.asarray(brdf.diffuse(o, i), np.float64)
                + scale[1] * np.asarray(brdf.specular(o, i), np.float64))
    f = np.asarray(brdf.eval(o, i), np.float64)
    if f.ndim == 1:
        f = np.repeat(f[:, None], 3, axis=1)
    return f[:, :3] if f.shape[1] >= 3 else np.repeat(f[:, :1], 3, axis=1)


def _mis_weight(pa, pb, mode):
    if mode == "balance":
        den = pa + pb
        return np.where(den > 0, pa / np.where(den > 0, den, 1.0), 0.0)
    a2, b2 = pa * pa, pb * pb
    den = a2 + b2
    return np.where(den > 0, a2 / np.where(den > 0, den, 1.0), 0.0)


def _to_world(v, t, b, n):
    return v[:, :1] * t + v[:, 1:2] * b + v[:, 2:3] * n


def _offset(pos, ng):
    scale = 1e-4 * np.maximum(1.0, np.abs(pos).max(axis=1, keepdims=True))
    return pos + ng * scale


def _visible(tracer, origin, dirs, tmax=np.inf):
    if tracer is None or len(origin) == 0:
        return np.ones(len(origin), bool)
    return ~tracer.occluded(origin, dirs, tmax=tmax, tnear=1e-5)


def _take(brdf, idx):
    """The BRDF of the rows idx: a per-row (textured) BRDF's subset, a uniform one itself."""
    return brdf.take(idx) if hasattr(brdf, "take") else brdf


def _object_brdf(brdfs, m, tex, sel):
    """Object m's BRDF for its rows sel: per-row glTF parameters where its material is
    textured (tex[2], sgpipe.reference.surface), else its material's BRDF."""
    brdf = brdfs[m]
    if tex is None or len(tex) < 3:
        return brdf
    p = tex[2][sel]
    if not np.isfinite(p[:, 0]).all():
        return brdf
    from sgpipe.brdf.gltf_rows import GltfRows
    return GltfRows(p[:, :3], p[:, 3], p[:, 4], p[:, 5])


def _technique(brdf, tracer, env, o, t, b, n, ng, org, tex, u1, u2, which, strategy, mis):
    """Contributions (N, 3) of one BRDF sample ("brdf") or one env sample ("env") per row."""
    nrow = len(o)
    out = np.zeros((nrow, 3))
    if which == "brdf":
        i_loc, pb = brdf.sample(o, u1, u2)
        i_loc = np.asarray(i_loc, np.float64)
        pb = np.asarray(pb, np.float64)
        ok = (pb > 0) & (i_loc[:, 2] > 0) & np.isfinite(pb) & np.isfinite(i_loc).all(axis=1)
        w_dir = _to_world(i_loc, t, b, n)
        ok &= np.einsum("ij,ij->i", w_dir, ng) > 0
        if not ok.any():
            return out
        idx = np.flatnonzero(ok)
        il, wd, p_own = i_loc[idx], w_dir[idx], pb[idx]
        rad, p_other = env.lookup(wd)
    else:
        wd_all, pe, rad_all = env.sample(u1, u2)
        i_loc = np.stack([np.einsum("ij,ij->i", wd_all, t), np.einsum("ij,ij->i", wd_all, b),
                          np.einsum("ij,ij->i", wd_all, n)], -1)
        ok = (pe > 0) & (i_loc[:, 2] > 0) & (np.einsum("ij,ij->i", wd_all, ng) > 0)
        if not ok.any():
            return out
        idx = np.flatnonzero(ok)
        il, wd, p_own, rad = i_loc[idx], wd_all[idx], pe[idx], rad_all[idx]
        p_other = (np.asarray(_take(brdf, idx).pdf(o[idx], il), np.float64)
                   if strategy == "mis" else None)
    f = _brdf_eval(_take(brdf, idx), o[idx], il,
                   None if tex is None else (tex[0][idx], tex[1][idx]))
    w = _mis_weight(p_own, p_other, mis) if strategy == "mis" else 1.0
    c = f * rad * (il[:, 2] * w / p_own)[:, None]
    live = np.flatnonzero((c > 0).any(axis=1) & np.isfinite(c).all(axis=1))
    if live.size:
        vis = _visible(tracer, org[idx[live]], wd[live])
        out[idx[live]] = c[live] * vis[:, None]
    return out


def _direct_lights(brdf, tracer, lights, o, t, b, n, ng, pos, org, tex, ul=None):
    """Contribution (P, 3) of the local lights (sgpipe.reference.lights): delta lights exactly,
    area lights with one cone sample each (uniforms `ul` (P, 2·lights))."""
    out = np.zeros((len(o), 3))
    for k, light in enumerate(lights):
        u1 = u2 = None
        if light[3] > 0:
            u1, u2 = ul[:, 2 * k], ul[:, 2 * k + 1]
        d, factor, tmax = light_samples(light, pos, u1, u2)
        il = np.stack([np.einsum("ij,ij->i", d, t), np.einsum("ij,ij->i", d, b),
                       np.einsum("ij,ij->i", d, n)], -1)
        ok = np.flatnonzero((il[:, 2] > 0) & (np.einsum("ij,ij->i", d, ng) > 0))
        if ok.size == 0:
            continue
        tx = None if tex is None else (tex[0][ok], tex[1][ok])
        c = _brdf_eval(_take(brdf, ok), o[ok], il[ok], tx) * factor[ok] * il[ok, 2:3]
        vis = _visible(tracer, org[ok], np.ascontiguousarray(d[ok]), tmax=tmax[ok])
        out[ok] += c * vis[:, None]
    return out


_CACHE: dict = {}


def _shared(task):
    """Per-process cache of the scene (tracer, env sampler, BRDFs) for one render call."""
    key = task["key"]
    if _CACHE.get("key") != key:
        from sgpipe.scene.gbuffer import Tracer
        shared = task["shared"]
        if isinstance(shared, str):
            with open(shared, "rb") as fh:
                shared = pickle.load(fh)
        _CACHE.clear()
        _CACHE.update(key=key, tracer=Tracer(shared["objects"]) if shared["objects"] else None,
                      env=shared["env"] if isinstance(shared["env"], EnvSampler)
                      else EnvSampler(shared["env"]),
                      brdfs=[_make_brdf(m) for m in shared["materials"]],
                      lights=shared["lights"], opts=shared["opts"], camera=shared["camera"],
                      maps=shared["maps"], filter=shared["filter"])
    return _CACHE


def _shade_hits(sh, rows, u, ul, strategy, mis):
    """Estimates (M, 3) of the hit rows: exact delta lights + one sample per technique."""
    brdfs, tracer, env, lights = sh["brdfs"], sh["tracer"], sh["env"], sh["lights"]
    pos, n, t, b, ng, view, obj, tex = (rows[k] for k in ("pos", "n", "t", "b", "ng", "view",
                                                          "obj", "tex"))
    o_loc = np.stack([np.einsum("ij,ij->i", view, t), np.einsum("ij,ij->i", view, b),
                      np.einsum("ij,ij->i", view, n)], -1)
    org = _offset(pos, ng)
    techniques = {"mis": ("brdf", "env"), "brdf": ("brdf",), "env": ("env",)}[strategy]
    out = np.zeros((len(pos), 3))
    for m in np.unique(obj):
        sel = np.flatnonzero(obj == m)
        tx = None if tex is None else (tex[0][sel], tex[1][sel])
        brdf = _object_brdf(brdfs, m, tex, sel)
        args = (o_loc[sel], t[sel], b[sel], n[sel], ng[sel])
        acc = _direct_lights(brdf, tracer, lights, *args, pos[sel], org[sel], tx,
                             None if ul is None else ul[sel])
        for k, which in enumerate(techniques):
            acc += _technique(brdf, tracer, env, *args, org[sel], tx, u[sel, 2 * k],
                              u[sel, 2 * k + 1], which, strategy, mis)
        out[sel] = acc
    return out


class _GivenRays:
    """Stands in for the camera of `surface.primary_rows`, which traces the rays `rays_at`
    returns: a bounce's continuation rays are given, not made from image-plane positions."""

    def __init__(self, origins, dirs):
        self.origins, self.dirs = origins, dirs

    def rays_at(self, px, py):
        return self.origins, self.dirs


def _continue(sh, rows, u1, u2):
    """BRDF-importance-sampled continuation of the paths at the hit rows: world directions
    (M, 3) and throughput factors f·cos θ/p (M, 3), zero where the sample failed or points
    below the geometric surface."""
    pos, n, t, b, ng, view, obj, tex = (rows[k] for k in ("pos", "n", "t", "b", "ng", "view",
                                                          "obj", "tex"))
    dirs = np.zeros((len(pos), 3))
    weight = np.zeros((len(pos), 3))
    for m in np.unique(obj):
        sel = np.flatnonzero(obj == m)
        o_loc = np.stack([np.einsum("ij,ij->i", view[sel], t[sel]),
                          np.einsum("ij,ij->i", view[sel], b[sel]),
                          np.einsum("ij,ij->i", view[sel], n[sel])], -1)
        brdf = _object_brdf(sh["brdfs"], m, tex, sel)
        i_loc, p = brdf.sample(o_loc, u1[sel], u2[sel])
        i_loc, p = np.asarray(i_loc, np.float64), np.asarray(p, np.float64)
        wd = _to_world(i_loc, t[sel], b[sel], n[sel])
        ok = ((p > 0) & (i_loc[:, 2] > 0) & np.isfinite(p) & np.isfinite(i_loc).all(axis=1)
              & (np.einsum("ij,ij->i", wd, ng[sel]) > 0))
        if not ok.any():
            continue
        k = sel[ok]
        tx = None if tex is None else (tex[0][k], tex[1][k])
        f = _brdf_eval(_take(brdf, ok), o_loc[ok], i_loc[ok], tx)
        dirs[k] = wd[ok] / np.linalg.norm(wd[ok], axis=1, keepdims=True)
        weight[k] = f * (i_loc[ok, 2] / p[ok])[:, None]
    return dirs, weight


def _shade_paths(sh, rows, u, ul, ub, strategy, mis, bounces):
    """Estimates (M, 3) of paths up to `bounces` indirect bounces: the direct estimate at the
    first hit (`_shade_hits`, the same numbers as without bounces) plus, per bounce, a BRDF-
    sampled continuation ray and the direct estimate (delta lights + MIS env/BRDF samples) at
    the surface it hits times the path throughput Π f·cos/p. Light reaching a vertex straight
    from the environment is the direct estimate's; a continuation that misses ends its path.
    No Russian roulette: every path runs its bounces (or ends where it leaves the scene).
    `ub` (M, bounces·(6 + 2·lights)): per bounce the continuation's 2 uniforms, the direct
    techniques' 4 and the area lights' 2 per light."""
    from sgpipe.reference.surface import primary_rows
    out = _shade_hits(sh, rows, u, ul, strategy, mis)
    n_l = 2 * len(sh["lights"]) if ul is not None else 0
    stride = 6 + n_l
    row_of = np.arange(len(out))          # original row of every live path
    beta = np.ones((len(out), 3))
    for k in range(bounces):
        uk = ub[row_of, k * stride:(k + 1) * stride]
        dirs, w = _continue(sh, rows, uk[:, 0], uk[:, 1])
        go = np.flatnonzero((w > 0).any(axis=1) & np.isfinite(w).all(axis=1))
        if go.size == 0 or sh["tracer"] is None:
            break
        org = _offset(rows["pos"][go], rows["ng"][go]) + _TNEAR * dirs[go]
        nxt = primary_rows(sh["tracer"], _GivenRays(org, dirs[go]), None, None, sh["maps"],
                           sh["opts"]["backfacing"])
        hit = go[nxt["idx"]]
        if hit.size == 0:
            break
        row_of, beta = row_of[hit], beta[hit] * w[hit]
        rows = {key: nxt[key] for key in ("pos", "n", "t", "b", "ng", "view", "obj", "tex")}
        uk = uk[hit]
        est = _shade_hits(sh, rows, uk[:, 2:6], uk[:, 6:] if n_l else None, strategy, mis)
        if nxt.get("emit") is not None:   # an emitting surface the bounce reaches
            est = est + nxt["emit"]
        out[row_of] += beta * est
    return out


def shade_tile(task) -> dict:
    """Render one tile (module-level for map_chunks): per pixel and sample a camera ray through
    the pixel filter's sub-pixel position, its first hit shaded (or the background where it
    misses); returns the per-pixel sums, sums of squares, hit counts and checkpoint sums."""
    from sgpipe.reference.pixel_filter import subpixel_positions
    from sgpipe.reference.surface import primary_rows
    sh = _shared(task)
    env, opts, filt = sh["env"], sh["opts"], sh["filter"]
    pid = task["pixel_ids"]
    rr, cc = task["rows"].astype(np.float64), task["cols"].astype(np.float64)
    npx = len(pid)
    spp, ck = opts["spp"], opts["checkpoints"]
    strategy, mis, seed = opts["strategy"], opts["mis"], opts["seed"]
    bounces = int(opts.get("bounces", 0))
    s_sum = np.zeros((npx, 3))
    s_sq = np.zeros((npx, 3))
    hits = np.zeros(npx, np.int64)
    ck_sums = []
    n_area = sum(L[3] > 0 for L in sh["lights"])
    centre = None
    if filt.type == "center":  # every sample takes the same ray: trace it once
        centre = primary_rows(sh["tracer"], sh["camera"], cc + 0.5, rr + 0.5, sh["maps"],
                              opts["backfacing"])
    per_pass = max(1, _ROWS_PER_PASS // max(npx, 1))
    done = 0
    bounds = sorted(set(ck) | {spp})
    while done < spp:
        nxt = min(done + per_pass, min(c for c in bounds if c > done))
        ns = nxt - done
        if centre is None:
            xy = subpixel_positions(filt, seed, pid, done, ns)          # (P, ns, 2)
            prim = primary_rows(sh["tracer"], sh["camera"], (cc[:, None] + xy[..., 0]).ravel(),
                                (rr[:, None] + xy[..., 1]).ravel(), sh["maps"],
                                opts["backfacing"])
            src = np.arange(npx * ns)
        else:
            prim, src = centre, np.repeat(np.arange(npx), ns)
        slot = np.full(len(prim["hit"]), -1, np.int64)                  # ray → hit row
        slot[prim["idx"]] = np.arange(len(prim["idx"]))
        h = slot[src]
        live = np.flatnonzero(h >= 0)
        est = np.zeros((npx * ns, 3))
        miss = np.flatnonzero(h < 0)
        if miss.size and opts["background"] == "env":
            est[miss] = env.lookup(prim["dirs"][src[miss]])[0]
        if live.size:
            take = {k: (None if prim[k] is None else
                        tuple(a[h[live]] for a in prim[k]) if k == "tex" else prim[k][h[live]])
                    for k in ("pos", "n", "t", "b", "ng", "view", "obj", "tex")}
            u = jit.uniforms(np.uint64(seed), pid.astype(np.int64), done, ns, 4).reshape(-1, 4)
            ul = None
            if n_area:   # the area lights' own stream: the other numbers stay as they were
                ul = jit.uniforms(np.uint64(seed ^ _LIGHT_STREAM), pid.astype(np.int64), done,
                                  ns, 2 * len(sh["lights"])).reshape(npx * ns, -1)[live]
            if bounces:  # interreflection: the bounces' own stream, the rest unchanged
                ub = jit.uniforms(np.uint64(seed ^ _BOUNCE_STREAM), pid.astype(np.int64), done,
                                  ns, bounces * (6 + (2 * len(sh["lights"]) if n_area else 0))
                                  ).reshape(npx * ns, -1)[live]
                est[live] = _shade_paths(sh, take, u[live], ul, ub, strategy, mis, bounces)
            else:
                est[live] = _shade_hits(sh, take, u[live], ul, strategy, mis)
            if prim.get("emit") is not None:
                est[live] += prim["emit"][h[live]]
        hits += (h >= 0).reshape(npx, ns).sum(axis=1)
        jit.accumulate(est, npx, ns, s_sum, s_sq)
        done = nxt
        if done in ck:
            ck_sums.append(s_sum.copy())
    return {"sum": s_sum, "sq": s_sq, "hits": hits, "checkpoints": ck_sums}
