"""SSDF shadows in the normal-map kernels (shading.h vis_*): a constant signed distance θ₀ over
the whole hemisphere (PCA mean θ₀, zero basis) occludes every light for θ₀ < 0 and leaves the
unshadowed shading for θ₀ > 0; FLAG_NO_VISIBILITY turns it off."""

from __future__ import annotations

import numpy as np
import pytest

from sgpipe.core.sh import sh_eval
from sgpipe.render.envdata import EnvData
from sgpipe.render.materials import pack_materials
from sgpipe.render.normalmap_data import (BRDF_MODELS, NormalMapData, attach_normalmaps,
                                          specular_sh_coeffs)
from sgpipe.render.records import KernelFlag
from sgpipe.render.renderer import ObjectShading, Renderer, VisObject
from tests.normalmap.render_mirror import (directional, flat_frame, material,
                                           single_lobe_pyramid, unit)

LIGHT = unit([0.3, -0.2, 0.9])


def _renderer(theta0, vis=True):
    _, m = material("blinn_phong", 50.0, kd=0.3, ks=0.7)
    res, nv = 8, 4
    v = VisObject(faces=np.array([[0, 1, 2]], np.int32), coeffs=np.zeros((3, nv), np.float32),
                  mean=np.full((res, res), theta0, np.float32),
                  basis=np.zeros((nv, res, res), np.float32))
    r = Renderer(env=EnvData.constant(0.0), materials=pack_materials([m]),
                 objects=[ObjectShading(0, vis=v if vis else None)], lights=[directional(LIGHT)])
    mu = unit([0.1, 0.0, 1.0])
    pyr = single_lobe_pyramid(mu, 80.0, sh=sh_eval(mu, 2))
    attach_normalmaps(r, NormalMapData.pack([pyr], [50.0], 1, [BRDF_MODELS["blinn_phong"]],
                                            [specular_sh_coeffs("blinn_phong", 50.0, 2)]))
    return r


@pytest.mark.parametrize("method", ["vmf", "toksvig", "nm_sh", "engine_bake"])
def test_constant_ssdf_shadows_the_light(method):
    n = 6
    rng = np.random.default_rng(1)
    views = unit(rng.normal(0, 0.3, (n, 3)) + [0, 0, 1.0])
    fr = flat_frame(views, np.full((n, 2), 0.3), np.tile([8.0, 0, 0, 8.0], (n, 1)))
    fr.tri[:] = 0
    fr.bary[:] = 0.3
    free = _renderer(0.0, vis=False).shade(method, fr)
    assert free.max() > 0.05
    np.testing.assert_allclose(_renderer(1.2).shade(method, fr), free, rtol=1e-4)
    assert np.abs(_renderer(-1.2).shade(method, fr)).max() < 1e-6 * free.max()
    np.testing.assert_allclose(_renderer(-1.2).shade(method, fr,
                                                     flags=KernelFlag.NO_VISIBILITY), free,
                               rtol=1e-4)
