"""Area lights of the `reference` (sgpipe.reference.lights, render.reference_area_lights): a
Lambert receiver that sees the whole sphere / disc gets exactly the delta light's radiance
(projected solid angle π sin²α cos β); an occluder edge through the light's axis blocks exactly
half of it (mirror symmetry); radius 0 or the option off is the delta light."""

import numpy as np
import pytest

from sgpipe.reference import render_reference_result
from sgpipe.reference.lights import light_samples, normalize_lights
from sgpipe.scene.camera import Camera
from sgpipe.scene.gbuffer import TraceObject, Tracer

LAMBERT = ("lambert", {"kd": [0.9, 0.6, 0.3]})


def _floor(half=2.0):
    v = np.array([[-half, 0, -half], [half, 0, -half], [half, 0, half], [-half, 0, half]], float)
    return TraceObject.mesh("floor", v, [[0, 2, 1], [0, 3, 2]])


@pytest.mark.parametrize("light", [
    {"type": "point", "position": [0.4, 1.5, -0.2], "intensity": [2.0, 1.5, 1.0], "radius": 0.4},
    {"type": "directional", "direction": [0.3, 1.0, 0.2], "intensity": [1.0, 2.0, 0.5],
     "radius": 0.3}])
def test_lambert_floor_sees_the_delta_lights_radiance(light):
    cam = Camera(eye=(0, 3, 3), target=(0, 0, 0), fov_deg=50, width=20, height=20)
    kw = dict(materials=[LAMBERT], lights=[light], seed=3, workers=1, background="black",
              pixel_filter="center")
    delta = render_reference_result([_floor()], cam, None, spp=1, **kw)
    area = render_reference_result([_floor()], cam, None, spp=64, area_lights=True, **kw)
    h = delta.hit
    assert h.sum() > 250 and np.all(area.stderr[h] > 0)            # it was sampled
    z = (area.image[h] - delta.image[h]) / area.stderr[h]
    pooled = (area.image[h] - delta.image[h]).sum(0) / np.sqrt((area.stderr[h] ** 2).sum(0))
    assert np.abs(pooled).max() < 4.5 and np.abs(z).max() < 6, (pooled, np.abs(z).max())
    # without the option, or with radius 0, the light is the delta light, bit for bit
    off = render_reference_result([_floor()], cam, None, spp=1, **kw)
    zero = render_reference_result([_floor()], cam, None, spp=1, area_lights=True,
                                   **{**kw, "lights": [{**light, "radius": 0.0}]})
    assert np.array_equal(off.image, delta.image) and np.array_equal(zero.image, delta.image)


@pytest.mark.parametrize("kind", ["point", "directional"])
def test_occluder_edge_through_the_axis_blocks_half_the_light(kind):
    """Floor point at the origin, light straight above, an opaque half-plane x > 0 at y = 1:
    the plane x = 0 bisects the light's cone and contains the normal, so exactly half of the
    cosine-weighted light is blocked; the delta light would be all or nothing."""
    spec = ({"type": "point", "position": [0, 2.0, 0], "intensity": 1.0, "radius": 0.5}
            if kind == "point" else
            {"type": "directional", "direction": [0, 1, 0], "intensity": 1.0, "radius": 0.25})
    light = normalize_lights([spec], area_lights=True)[0]
    card = TraceObject.mesh("card", np.array([[0, 1, -5], [5, 1, -5], [5, 1, 5], [0, 1, 5]],
                                             float), [[0, 1, 2], [0, 2, 3]])
    n = 200_000
    rng = np.random.default_rng(1)
    pos = np.zeros((n, 3))
    d, factor, tmax = light_samples(light, pos, rng.random(n), rng.random(n))
    assert np.all(tmax > 0) and np.all(d[:, 1] > 0)
    if kind == "point":   # shadow rays end on the light's near surface
        np.testing.assert_allclose(np.linalg.norm(d * tmax[:, None] - [0, 2.0, 0], axis=1),
                                   0.5, rtol=1e-6)
    w = factor[:, 0] * d[:, 1]                                    # E·cos per sample
    vis = ~Tracer([card]).occluded(pos + [0, 1e-4, 0], d, tmax=tmax)
    frac = np.mean(w * vis) / np.mean(w)
    se = np.std(w * vis) / np.sqrt(n) / np.mean(w)
    assert abs(frac - 0.5) < 5 * se + 1e-9, (frac, se)
    # unoccluded, the mean is the delta light's irradiance (π sin²α cos β, β = 0)
    e_delta = 1.0 / 4.0 if kind == "point" else 1.0
    assert np.mean(w) == pytest.approx(e_delta, rel=5 * np.std(w) / np.sqrt(n) / np.mean(w))
