"""The `reference` method's driver (contract: sgpipe.reference): 32×32 pixel tiles mapped over
workers (`shading.shade_tile`: per sample a camera ray through the pixel filter, its first hit
shaded), and the image, standard error and progressive checkpoints assembled from the tiles'
sums."""

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
from sgpipe.reference.lights import normalize_lights
from sgpipe.reference.shading import _CACHE, _material_key, shade_tile

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
    coverage: np.ndarray | None = None     # (H, W) float32 fraction of samples that hit

    @property
    def samples_per_s(self) -> float:
        return self.samples / self.seconds if self.seconds > 0 else float("inf")


def render_reference_result(objects, camera, env, *, materials, lights=(), spp: int = 64,
                            seed: int = 0, workers: int | None = None,
                            progressive_every: int = 0, strategy: str = "mis",
                            mis: str = "power", background: str | bool = "env",
                            pixel_filter=None, maps=None,
                            area_lights: bool = False, bounces: int = 0,
                            env_rotation=None, mapped_backfacing: str = "lift"
                            ) -> ReferenceResult:
    """Render and return image, standard error, timing and progressive checkpoints.

    `pixel_filter`: a `PixelFilter`, its type name or a dict (type, radius, stddev); None is
    the box filter over the pixel. `maps`: per object (aligned with `objects`) an `ObjectMaps`
    (or dict) of normal map and kd / ks multipliers, or None. `area_lights`: lights with a
    `radius` > 0 are spheres / discs of that size (sgpipe.reference.lights), else delta lights.
    `bounces`: indirect bounces per path (0: direct lighting only; shading._shade_paths).
    `env_rotation`: 3×3 world ← map rotation of the environment (EnvSampler.rotated), or None.
    `mapped_backfacing`: "lift" or "black", where a view lies behind a mapped normal
    (surface.primary_rows).
    """
    from sgpipe.parallel import map_chunks, on_cluster
    from sgpipe.reference.pixel_filter import PixelFilter
    from sgpipe.reference.surface import ObjectMaps
    from sgpipe.scene.gbuffer import Tracer

    if strategy not in ("mis", "brdf", "env"):
        raise ValueError(f"strategy must be mis, brdf or env, got {strategy!r}")
    if mis not in ("power", "balance"):
        raise ValueError(f"mis must be power or balance, got {mis!r}")
    if isinstance(background, bool):
        background = "env" if background else "black"
    if background not in ("env", "black"):
        raise ValueError(f"background must be env or black, got {background!r}")
    if mapped_backfacing not in ("lift", "black"):
        raise ValueError(f"mapped_backfacing must be lift or black, got {mapped_backfacing!r}")
    bounces = int(bounces)
    if bounces < 0:
        raise ValueError("bounces must be >= 0")
    spp = int(spp)
    if spp < 1:
        raise ValueError("spp must be >= 1")
    objects = list(objects)
    mats = [_material_key(m) for m in materials]
    if len(mats) != len(objects):
        raise ValueError(f"{len(mats)} materials for {len(objects)} objects")
    maps = [ObjectMaps.of(m) for m in (maps if maps is not None else [None] * len(objects))]
    if len(maps) != len(objects):
        raise ValueError(f"{len(maps)} object maps for {len(objects)} objects")
    filt = PixelFilter.of(pixel_filter)
    t0 = time.perf_counter()
    env_s = (env if isinstance(env, EnvSampler) else EnvSampler(env)).rotated(env_rotation)
    h, w = camera.height, camera.width
    # the pixel-centre hit mask (the other methods' G-buffer), reported as `hit`
    origins, dirs = camera.rays()
    centre_hit = (Tracer(objects).trace(origins, dirs).hit if objects
                  else np.zeros((h, w), bool))
    every = int(progressive_every or 0)
    cks = list(range(every, spp, every)) + [spp] if every > 0 else [spp]
    opts = {"spp": spp, "checkpoints": cks, "strategy": strategy, "mis": mis,
            "seed": int(seed), "background": background, "bounces": bounces,
            "backfacing": mapped_backfacing}
    shared = {"objects": objects, "env": env_s, "materials": mats,
              "lights": normalize_lights(lights, area_lights), "opts": opts, "camera": camera,
              "maps": maps, "filter": filt}
    tasks = []
    key = uuid.uuid4().hex
    tmpdir = None
    for r0 in range(0, h, TILE):
        for c0 in range(0, w, TILE):
            rr, cc = np.indices((min(TILE, h - r0), min(TILE, w - c0)))
            rr, cc = (rr.ravel() + r0).astype(np.int64), (cc.ravel() + c0).astype(np.int64)
            tasks.append({"key": key, "rows": rr, "cols": cc, "pixel_ids": rr * w + cc})
    n_work = 1 if len(tasks) <= 1 else (workers or None)
    if n_work is None and int(centre_hit.sum()) * spp < _MIN_SAMPLES_PER_PROCESS_POOL:
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
    img = np.zeros((h, w, 3))
    err = np.zeros((h, w, 3))
    cover = np.zeros((h, w))
    ck_imgs = [np.zeros((h, w, 3)) for _ in cks]
    for tk, res in zip(tasks, results):
        rr, cc = tk["rows"], tk["cols"]
        mean = res["sum"] / spp
        var = np.maximum(res["sq"] / spp - mean * mean, 0.0) * spp / max(spp - 1, 1)
        img[rr, cc] = mean
        err[rr, cc] = np.sqrt(var / spp)
        cover[rr, cc] = res["hits"] / spp
        for k, (c, s) in enumerate(zip(cks, res["checkpoints"])):
            ck_imgs[k][rr, cc] = s / c
    seconds = time.perf_counter() - t0
    n_tech = 2 if strategy == "mis" else 1
    return ReferenceResult(image=img.astype(np.float32), stderr=err.astype(np.float32),
                           hit=centre_hit, spp=spp, seconds=seconds,
                           samples=int(round(cover.sum() * spp)) * n_tech,
                           checkpoints=[(c, im.astype(np.float32)) for c, im in zip(cks, ck_imgs)],
                           coverage=cover.astype(np.float32))


def _single_core() -> bool:
    from sgpipe.parallel import default_workers
    return default_workers() == 1


def render_reference(objects, camera, env, *, materials, lights=(), spp: int = 64,
                     seed: int = 0, workers: int | None = None, **kw) -> np.ndarray:
    """Monte Carlo reference image (H, W, 3) float32; see sgpipe.reference."""
    return render_reference_result(objects, camera, env, materials=materials, lights=lights,
                                   spp=spp, seed=seed, workers=workers, **kw).image
