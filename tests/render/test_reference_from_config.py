"""The one config → `reference` path (sgpipe.stages.render.reference_from_config) against the
explicit call of sgpipe.reference with the values the config names."""

from pathlib import Path

import numpy as np
import pytest

from sgpipe.config.sections.render import LightSpec
from sgpipe.errors import BadInput
from sgpipe.experiments.figures import build_config
from sgpipe.io import read_exr
from sgpipe.reference import render_reference_result
from sgpipe.scene.camera import Camera
from sgpipe.scene.gbuffer import TraceObject
from sgpipe.stages.render import reference_from_config

DATA = Path(__file__).resolve().parents[2] / "data_samples"


def test_reference_from_config_matches_direct_call():
    """Config → objects, env × exposure, materials, lights, spp, seed, background equals the
    explicit call; an undefined material is BadInput naming it."""
    mats = [{"name": "w", "model": "ward", "params": {"alpha": 0.2, "kd": 0.3, "ks": 0.5}}]
    cfg = build_config(DATA / "studio.exr", mats, "w", ["reference"], size=12, spp=4, seed=5,
                       workers=1)
    cfg.render.environment_exposure = 1.0
    cfg.render.lights = [LightSpec(type="directional", direction=(0.0, 1.0, 1.0),
                                   intensity=(0.5, 0.4, 0.3))]
    res = reference_from_config(cfg)
    cam = Camera.from_spec(cfg.render.camera)
    light = {"type": "directional", "direction": [0.0, 1.0, 1.0], "irradiance": [0.5, 0.4, 0.3]}
    direct = render_reference_result([TraceObject.sphere("sphere", (0, 0, 0), 1.0)], cam,
                                     2.0 * read_exr(DATA / "studio.exr"),
                                     materials=[("ward", mats[0]["params"])], lights=[light],
                                     spp=4, seed=5, workers=1, background="black")
    np.testing.assert_array_equal(res.image, direct.image)
    no_light = render_reference_result([TraceObject.sphere("sphere", (0, 0, 0), 1.0)], cam,
                                       2.0 * read_exr(DATA / "studio.exr"),
                                       materials=[("ward", mats[0]["params"])], spp=4, seed=5,
                                       workers=1, background="black")
    assert not np.array_equal(res.image, no_light.image)      # the light reached the reference
    cfg.scene.objects[0].material = "nope"
    with pytest.raises(BadInput, match="nope"):
        reference_from_config(cfg)
