"""Fidelity floors in CI: sg on GGX α 0.1 + red diffuse under the studio map, gmm on a Beckmann
α 0.2 sphere under the sky with a sun, sg on a GGX α 0.1 sphere under that sun and under a point
light alone, sg and fis on the glTF metal-rough BRDF (and its anisotropy turned by
KHR_materials_anisotropy's rotation) under the point light, through the real stages (fit →
precompute → render, 3×3 supersampled) at 48²,
against a two-seed Monte Carlo reference (box filter), surface display PSNR corrected for the
reference's noise (benchmarks/bench_fidelity.py).

Each floor sits between the fidelity it guards and the regression it catches, and the regression
is rendered here too where a setting brings it back: sg with two NDF lobes (`fit.ndf_sg.lobes:
2`, the old GGX fit), gmm without the environment's point set (`render.gmm_points: false`) and
sg shading the sun through its lobes (`envmap.pyramid_max_points: 0`) instead of the exact BRDF
must fall below their floors."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

pytestmark = [pytest.mark.opencl, pytest.mark.slow]

ROOT = Path(__file__).resolve().parents[2]
_BENCH = ROOT / "benchmarks" / "bench_fidelity.py"
_spec = importlib.util.spec_from_file_location("bench_fidelity_floors", _BENCH)
_bench = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(_bench)      # benchmarks/ is not an installed package

SIZE = 48
SIZE_OVERRIDES = (f"render.camera.width={SIZE}", f"render.camera.height={SIZE}")
SCENES = ROOT / "validation" / "scenes"

# GGX scene: the reference at 2 × 512 spp has a 43 dB surface noise floor (37 dB seed A vs B);
# sg with the lobe rule clears the floor, with 2 lobes (33.9 dB when measured) it does not.
GGX_SCENE = SCENES / "ggx_a0.1_red_diffuse_studio.yaml"
GGX_SPP = 512
GGX_OVERRIDES = SIZE_OVERRIDES + ("fit.view_gmm.enabled=false",)   # sg does not read view GMMs
SG_FLOOR_DB = 37.5

# Sun scene: reference at 2 × 256 spp, ~49 dB surface noise floor; measured gmm 44.9–45.3 dB
# with the point set, 31.3 dB without.
SUN_SCENE = SCENES / "beckmann_a0.05_sky_sun.yaml"
SUN_SPP = 256
SUN_OVERRIDES = SIZE_OVERRIDES + ("fit.materials.0.params.alpha=0.2",)
GMM_FLOOR_DB = 39.0

# The same sun scene with GGX α 0.1 for sg: the point set (the sun) with the exact BRDF,
# measured 48.6 dB (raw 45.8); through the NDF lobes, whose Gaussian fall-off loses GGX's tail
# that the sun lifts above white, 33.4 dB.
SUN_GGX_OVERRIDES = SIZE_OVERRIDES + ("fit.materials.0.model=ggx",
                                      "fit.materials.0.params.alpha=0.1",
                                      "fit.view_gmm.enabled=false")
SG_SUN_FLOOR_DB = 42.0
# ... and lit only by a point light (the map 2^-30 dark): the exact BRDF at the light, measured
# 66.9 dB; the lobes' value there (the code before), 36.1 dB.
POINT_GGX_OVERRIDES = SUN_GGX_OVERRIDES + (
    "render.environment_exposure=-30",
    "render.lights=[{type: point, position: [2.0, 2.5, 3.0], intensity: [30, 30, 30], "
    "radius: 0.0}]")
SG_POINT_FLOOR_DB = 50.0

#: the noise floor must clear the method's floor by this much for the corrected PSNR to mean
#: something (bench_fidelity._noisy: within 3 dB the estimate is only a lower bound)
NOISE_MARGIN_DB = 3.0


def _surface(result: dict, method: str) -> dict:
    assert method in result["methods"], result["errors"]
    return result["methods"][method]


def _report(tag: str, v: dict) -> None:
    print(f"{tag}: surface {v['surface_display_psnr_db']:.2f} dB (raw "
          f"{v['raw_surface_display_psnr_db']:.2f}, reference noise floor "
          f"{v['surface_floor_db']:.2f})")


def _holds_floor(result: dict, method: str, floor: float, tag: str) -> None:
    """The method clears its floor, and the reference's noise floor clears it by the margin."""
    v = _surface(result, method)
    _report(tag, v)
    assert v["surface_floor_db"] > floor + NOISE_MARGIN_DB
    assert v["surface_display_psnr_db"] >= floor


def _falls_below(scene, method: str, overrides, floor: float, tag: str, truth: dict) -> None:
    """The regression case, against the same reference, scores under the floor."""
    r = _bench.measure(scene, (method,), overrides, reference=truth["reference"])
    v = _surface(r, method)
    _report(tag, v)
    assert v["surface_display_psnr_db"] < floor


@pytest.fixture(scope="module")
def ggx_sg():
    """sg on the GGX scene with the default lobe rule; its reference is reused below."""
    return _bench.measure(GGX_SCENE, ("sg",), GGX_OVERRIDES, spp=GGX_SPP)


@pytest.fixture(scope="module")
def sun_gmm():
    """gmm with the environment's point set on the sun scene; its reference is reused below."""
    return _bench.measure(SUN_SCENE, ("gmm",), SUN_OVERRIDES + ("render.gmm_points=true",),
                          spp=SUN_SPP)


@pytest.fixture(scope="module")
def sun_ggx_sg():
    """sg on a GGX α 0.1 sphere under the sky with its sun; its reference is reused below."""
    return _bench.measure(SUN_SCENE, ("sg",), SUN_GGX_OVERRIDES, spp=SUN_SPP)


def test_sg_ggx_floor(ggx_sg):
    _holds_floor(ggx_sg, "sg", SG_FLOOR_DB, "sg GGX lobe rule")


def test_sg_floor_catches_two_lobe_ggx_fit(ggx_sg):
    _falls_below(GGX_SCENE, "sg", GGX_OVERRIDES + ("fit.ndf_sg.lobes=2",), SG_FLOOR_DB,
                 "sg GGX 2 lobes", ggx_sg)


def test_gmm_sun_floor(sun_gmm):
    _holds_floor(sun_gmm, "gmm", GMM_FLOOR_DB, "gmm sun with points")


def test_gmm_floor_catches_missing_point_set(sun_gmm):
    _falls_below(SUN_SCENE, "gmm", SUN_OVERRIDES + ("render.gmm_points=false",), GMM_FLOOR_DB,
                 "gmm sun without points", sun_gmm)


def test_sg_sun_ggx_floor(sun_ggx_sg):
    _holds_floor(sun_ggx_sg, "sg", SG_SUN_FLOOR_DB, "sg GGX sun, exact BRDF at the point set")


def test_sg_sun_floor_catches_sun_through_lobes(sun_ggx_sg):
    _falls_below(SUN_SCENE, "sg", SUN_GGX_OVERRIDES + ("envmap.pyramid_max_points=0",),
                 SG_SUN_FLOOR_DB, "sg GGX sun through the lobes", sun_ggx_sg)


def test_sg_point_light_ggx_floor():
    r = _bench.measure(SUN_SCENE, ("sg",), POINT_GGX_OVERRIDES, spp=SUN_SPP)
    _holds_floor(r, "sg", SG_POINT_FLOOR_DB, "sg GGX point light, exact BRDF")


# The glTF 2.0 metal-rough BRDF (`gltf_pbr`, half metal, roughness 0.5) lit by the point light
# alone: sg and fis evaluate the BRDF exactly at the light, measured 68.0 / 69.6 dB (noise floor
# 71.5); the same factors read as the separable-Smith GGX with a Lambert layer (what a kernel
# without the glTF shadowing and diffuse kinds would render) measured 45.2 dB.
GLTF_MATERIAL = ("fit.materials.0.model=gltf_pbr",
                 "fit.materials.0.params={base_color: [0.3, 0.5, 0.8], metallic: 0.5, "
                 "roughness: 0.5}")
POINT_GLTF_OVERRIDES = POINT_GGX_OVERRIDES + GLTF_MATERIAL
GLTF_POINT_FLOOR_DB = 55.0


# KHR_materials_anisotropy (strength 0.8, rotation 0.7 rad) on the same BRDF under the point
# light: the reference turns its shading frame, the kernels their BRDF frame (pixel_init's
# quaternion); the exact BRDF at the light (its NDF table over 64 azimuths) meets the reference
# only where both turn the same way: measured sg and fis 50.6 dB (48.97 for the same material not
# turned, against its own reference), 27 dB with the kernels 0.1 rad off, 13-14 dB turned the
# other way or not at all.
ANISO_GLTF = ("fit.materials.0.model=gltf_pbr",
              "fit.materials.0.params={base_color: [0.3, 0.5, 0.8], metallic: 0.8, "
              "roughness: 0.35, anisotropy: 0.8, anisotropy_rotation: %s}")
ANISO_POINT_FLOOR_DB = 45.0


def test_gltf_anisotropy_rotation_point_light_floor():
    r = _bench.measure(SUN_SCENE, ("sg", "fis"), POINT_GGX_OVERRIDES + (ANISO_GLTF[0],
                       ANISO_GLTF[1] % "0.7"), spp=SUN_SPP)
    _holds_floor(r, "sg", ANISO_POINT_FLOOR_DB, "sg glTF anisotropy turned 0.7 rad")
    _holds_floor(r, "fis", ANISO_POINT_FLOOR_DB, "fis glTF anisotropy turned 0.7 rad")
    _falls_below(SUN_SCENE, "sg", POINT_GGX_OVERRIDES + (ANISO_GLTF[0], ANISO_GLTF[1] % "-0.7"),
                 ANISO_POINT_FLOOR_DB, "sg turned the other way", r)
    _falls_below(SUN_SCENE, "sg", POINT_GGX_OVERRIDES + (ANISO_GLTF[0], ANISO_GLTF[1] % "0"),
                 ANISO_POINT_FLOOR_DB, "sg not turned", r)


def test_gltf_pbr_point_light_floor():
    r = _bench.measure(SUN_SCENE, ("sg", "fis"), POINT_GLTF_OVERRIDES, spp=SUN_SPP)
    _holds_floor(r, "sg", GLTF_POINT_FLOOR_DB, "sg glTF BRDF point light")
    _holds_floor(r, "fis", GLTF_POINT_FLOOR_DB, "fis glTF BRDF point light")
    _falls_below(SUN_SCENE, "sg", POINT_GGX_OVERRIDES + (
        "fit.materials.0.params={alpha: 0.25, kd: [0.15, 0.25, 0.4], ks: 1.0, "
        "fresnel: schlick, f0: [0.17, 0.27, 0.42]}",), GLTF_POINT_FLOOR_DB,
        "the glTF factors as separable GGX + Lambert", r)
