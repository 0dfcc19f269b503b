"""The `reference` method's driver (contract: sgpipe.reference): primary rays, 32×32 tiles of hit
pixels mapped over workers (`shading.shade_tile`), and the image, standard error and progressive
checkpoints assembled from the tiles' sums."""

from __future__ import annotations

import pickle
import shutil
import tempfile
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sgpipe.reference.sampler import EnvSampler
from sgpipe.reference.shading import _CACHE, _material_key, normalize_lights, shade_tile

TILE = 32
_MIN_SAMPLES_PER_PROCESS_POOL = 4_000_000  # pixel-samples; below this `workers=None` uses 1


# --- the public entry points ----------------------------------------------------------------
@dataclass
class ReferenceResult:
    """What `render_reference_result` returns."""

    image: np.ndarray                      # (H, W, 3) float32 mean radiance
    stderr: np.ndarray                     # (H, W, 3) float32 standard error of the mean
    hit: np.ndarray                        # (H, W) bool
    spp: int
    seconds: float
    samples: int                           # hit pixels × spp × techniques
    checkpoints: list = field(default_factory=list)  # [(spp, (H, W, 3) float32), ...]

    @property
    def samples_per_s(self) -> float:
        return self.samples / self.seconds if self.seconds > 0 else float("inf")


def render_reference_result(objects, camera, env, *, materials, lights=(), spp: int = 64,
                            seed: int = 0, workers: int | None = None,
                            progressive_every: int = 0, strategy: str = "mis",
                            mis: str = "power", background: str | bool = "env",
                            gbuffer=None, kd_scale=None, ks_scale=None) -> ReferenceResult:
    """Render and return image, standard error, timing and progressive checkpoints.

    `gbuffer`: a precomputed `GBuffer` of `camera.rays()` (e.g. with normal-mapped shading
    normals/tangents) used instead of tracing; `kd_scale` / `ks_scale`: (H, W, 3) texture
    multipliers of the diffuse / specular terms (SVBRDF), applied as
    kd_scale·brdf.diffuse + ks_scale·brdf.specular (registry BRDFs only).
    """
    from sgpipe.parallel import map_chunks, on_cluster
    from sgpipe.scene.gbuffer import Tracer

    if strategy not in ("mis", "brdf", "env"):
        raise ValueError(f"strategy must be mis, brdf or env, got {strategy!r}")
    if mis not in ("power", "balance"):
        raise ValueError(f"mis must be power or balance, got {mis!r}")
    if isinstance(background, bool):
        background = "env" if background else "black"
    if background not in ("env", "black"):
        raise ValueError(f"background must be env or black, got {background!r}")
    spp = int(spp)
    if spp < 1:
        raise ValueError("spp must be >= 1")
    objects = list(objects)
    mats = [_material_key(m) for m in materials]
    if len(mats) != len(objects):
        raise ValueError(f"{len(mats)} materials for {len(objects)} objects")
    t0 = time.perf_counter()
    env_s = env if isinstance(env, EnvSampler) else EnvSampler(env)
    origins, dirs = camera.rays()
    h, w = origins.shape[:2]
    gb = gbuffer if gbuffer is not None else (Tracer(objects).trace(origins, dirs)
                                               if objects else None)
    if gb is not None and gb.hit.shape != (h, w):
        raise ValueError(f"gbuffer shape {gb.hit.shape} does not match the camera {(h, w)}")
    tex_maps = None
    if kd_scale is not None or ks_scale is not None:
        one = np.ones((h, w, 3))
        tex_maps = tuple(one if a is None else np.broadcast_to(np.asarray(a, np.float64),
                                                               (h, w, 3)) for a in
                         (kd_scale, ks_scale))
    every = int(progressive_every or 0)
    cks = list(range(every, spp, every)) + [spp] if every > 0 else [spp]
    opts = {"spp": spp, "checkpoints": cks, "strategy": strategy, "mis": mis,
            "seed": int(seed)}
    shared = {"objects": objects, "env": env_s.rgb, "materials": mats,
              "lights": normalize_lights(lights), "opts": opts}
    tasks = []
    key = uuid.uuid4().hex
    tmpdir = None
    if gb is not None:
        for r0 in range(0, h, TILE):
            for c0 in range(0, w, TILE):
                hit = gb.hit[r0:r0 + TILE, c0:c0 + TILE]
                if not hit.any():
                    continue
                rr, cc = np.nonzero(hit)
                rr, cc = rr + r0, cc + c0
                task = {"key": key, "rows": rr, "cols": cc,
                        "pixel_ids": (rr * w + cc).astype(np.int64),
                        "material": gb.object_id[rr, cc].astype(np.int64)}
                for name in ("position", "normal", "tangent", "bitangent", "geo_normal",
                             "view"):
                    task[name] = getattr(gb, name)[rr, cc]
                if tex_maps is not None:
                    task["tex"] = (tex_maps[0][rr, cc], tex_maps[1][rr, cc])
                tasks.append(task)
    n_work = 1 if len(tasks) <= 1 else (workers or None)
    n_hit = int(gb.hit.sum()) if gb is not None else 0
    if n_work is None and n_hit * spp < _MIN_SAMPLES_PER_PROCESS_POOL:
        n_work = 1  # starting worker processes (~2 s) costs more than this render
    try:
        # On a cluster the tiles may run on other machines: they carry the scene themselves
        # instead of naming a pickle in this machine's /tmp.
        if n_work == 1 or on_cluster() or (n_work is None and _single_core()):
            n_work = 1
            shared["env"] = env_s
            for tk in tasks:
                tk["shared"] = shared
        else:
            tmpdir = tempfile.mkdtemp(prefix="sgpipe-ref-")
            path = str(Path(tmpdir) / "shared.pkl")
            with open(path, "wb") as fh:
                pickle.dump(shared, fh, protocol=pickle.HIGHEST_PROTOCOL)
            for tk in tasks:
                tk["shared"] = path
        results = map_chunks(shade_tile, tasks, workers=n_work, desc="reference")
    finally:
        if tmpdir:
            shutil.rmtree(tmpdir, ignore_errors=True)
        _CACHE.clear()
    bg = np.zeros((h, w, 3))
    if background == "env":
        rad, _ = env_s.lookup(np.asarray(dirs, np.float64).reshape(-1, 3))
        bg = rad.reshape(h, w, 3)
    hit = gb.hit if gb is not None else np.zeros((h, w), bool)
    img = np.where(hit[..., None], 0.0, bg)
    err = np.zeros((h, w, 3))
    ck_imgs = [img.copy() for _ in cks]
    for tk, res in zip(tasks, results):
        rr, cc = tk["rows"], tk["cols"]
        mean = res["sum"] / spp
        var = np.maximum(res["sq"] / spp - mean * mean, 0.0) * spp / max(spp - 1, 1)
        img[rr, cc] = mean + res["direct"]
        err[rr, cc] = np.sqrt(var / spp)
        for k, (c, s) in enumerate(zip(cks, res["checkpoints"])):
            ck_imgs[k][rr, cc] = s / c + res["direct"]
    seconds = time.perf_counter() - t0
    n_tech = 2 if strategy == "mis" else 1
    return ReferenceResult(image=img.astype(np.float32), stderr=err.astype(np.float32),
                           hit=hit, spp=spp, seconds=seconds,
                           samples=int(hit.sum()) * spp * n_tech,
                           checkpoints=[(c, im.astype(np.float32)) for c, im in zip(cks, ck_imgs)])


def _single_core() -> bool:
    from sgpipe.parallel import default_workers
    return default_workers() == 1


def render_reference(objects, camera, env, *, materials, lights=(), spp: int = 64,
                     seed: int = 0, workers: int | None = None, **kw) -> np.ndarray:
    """Monte Carlo reference image (H, W, 3) float32; see sgpipe.reference."""
    return render_reference_result(objects, camera, env, materials=materials, lights=lights,
                                   spp=spp, seed=seed, workers=workers, **kw).image
