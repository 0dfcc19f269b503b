"""`reference` method: Monte Carlo ground truth of direct lighting (environment + delta lights).

    from sgpipe.reference import render_reference
    img = render_reference(objects, camera, env, materials=mats, lights=lights,
                           spp=256, seed=0, workers=None)          # (H, W, 3) float32

* `objects`: list of `sgpipe.scene.gbuffer.TraceObject`; `camera`: `sgpipe.scene.camera.Camera`.
* `materials`: one per object, aligned with `objects`: a BRDF object of the registry
  (`eval/sample/pdf`, e.g. `sgpipe.brdf.brdf_from_spec(spec)` of a config material), or
  `(model, params)` / `{"model", "params"}`, built in each worker with `sgpipe.brdf.make_brdf`.
* `env`: lat-long (H, W, 3) linear radiance array or EXR path (CONVENTIONS mapping), or None (black).
  The environment is *piecewise constant*: the radiance of a direction is its texel's value
  (the sample maps store texel means, so Σ texel·Ω is the exact integral).
* `lights`: point / directional lights, dicts or objects with `type` ("directional" | "point"),
  `direction` (directional: unit vector from the scene TOWARDS the light), `position` (point),
  and `irradiance` (directional: RGB W/m² on a surface facing the light) or `intensity`
  (point: RGB W/sr). Each adds f·E·cos θ·V (point: f·I·cos θ·V/r²), evaluated exactly; with
  `area_lights=True` a light's `radius` makes it a sphere / disc of uniform radiance sampled in
  its cone (sgpipe.reference.lights).

Per pixel the estimator integrates over the pixel footprint with a reconstruction filter
(`pixel_filter`: box over the pixel by default, tent, Gaussian, or `center` = one ray through
the pixel centre like the real-time methods; sgpipe.reference.pixel_filter): each sample takes
its own camera ray through a sub-pixel position drawn from the filter (a per-pixel shifted R2
low-discrepancy pattern), traced with Embree in batches (`surface.primary_rows`); misses add the
background, hits add the exact delta lights plus an estimate of
L_o = ∫ f(o, i) L_env(i) cos θ_i V(i) dω_i from one BRDF sample and one
environment sample combined with multiple importance sampling (Veach 1997; `mis="power"` β=2,
or `"balance"`); `strategy="brdf"` / `"env"` use one technique alone (same spp, for the
unbiasedness tests). Visibility: shadow rays through `Tracer.occluded` (Embree for meshes,
analytic spheres), offset along the geometric normal; directions below the geometric surface
are black. Misses show the environment (`background="env"`) or black.
`maps` (per object `surface.ObjectMaps`): tangent-space normal maps and kd / ks texture
multipliers, with the kernels' conventions (shading.h `pixel_init`).

Random numbers are counter-based (seed, pixel id, sample index, dimension; see
`_sampling_jit.uniforms`), pixels are split into fixed 32×32 tiles mapped with
`sgpipe.parallel.map_chunks`: the image is bit-identical for a seed whatever the worker count.
`progressive_every=k` records the image after every k spp (`ReferenceResult.checkpoints`);
the image after n spp does not depend on k. `render_reference_result` also returns the
per-pixel standard error of the mean (from the sample variance) and timing. From a validated
config: `sgpipe.stages.render.reference_from_config(cfg)` (the one config → reference path).
Light config objects with `vector` (renderer `Light`) are accepted too.
"""

from sgpipe.reference.driver import (TILE, ReferenceResult, render_reference,
                                     render_reference_result)
from sgpipe.reference.pixel_filter import FILTER_TYPES, PixelFilter
from sgpipe.reference.sampler import EnvSampler
from sgpipe.reference.lights import normalize_lights
from sgpipe.reference.surface import ObjectMaps

__all__ = ["render_reference", "render_reference_result", "ReferenceResult", "EnvSampler",
           "normalize_lights", "TILE", "PixelFilter", "FILTER_TYPES", "ObjectMaps"]
