"""Texture footprints on curved surfaces (sgpipe.scene.footprint, Igehy 1999 ray differentials;
Han07 §7.3 picks the MIP level from them) and the normal-map kernels' finest level there:
the UV derivatives of a lat-long UV sphere mesh and of the analytic sphere against central
finite differences of the traced UVs; `vmf` and `normals_mip` identical where the footprint
is below one texel (both then shade the unit bilinear normal, as the reference reads the map)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sgpipe.io.mesh import uv_tangents
from sgpipe.scene.camera import Camera
from sgpipe.scene.footprint import mip_level, uv_derivatives
from sgpipe.scene.gbuffer import TraceObject, Tracer

SIZE = 48


def uv_sphere(n_phi=72, n_theta=36, repeat=(1.0, 1.0)):
    """Unit UV sphere (y up) with a seam column: u = φ/2π, v = 1 − θ/π (× repeat), vertex
    normals = positions (data_samples/sphere.obj's layout)."""
    th = np.linspace(0.0, np.pi, n_theta + 1)
    ph = np.linspace(0.0, 2 * np.pi, n_phi + 1)
    T, P = np.meshgrid(th, ph, indexing="ij")
    pos = np.stack([np.sin(T) * np.sin(P), np.cos(T), -np.sin(T) * np.cos(P)], -1).reshape(-1, 3)
    uv = np.stack([P / (2 * np.pi) * repeat[0], (1 - T / np.pi) * repeat[1]], -1).reshape(-1, 2)
    idx = np.arange((n_theta + 1) * (n_phi + 1)).reshape(n_theta + 1, n_phi + 1)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    faces = np.concatenate([np.stack([a, b, c], 1), np.stack([b, d, c], 1)])  # outward
    area = np.linalg.norm(np.cross(pos[faces[:, 1]] - pos[faces[:, 0]],
                                   pos[faces[:, 2]] - pos[faces[:, 0]]), axis=1)
    faces = faces[area > 1e-12]                    # the poles' degenerate triangles
    t, _ = uv_tangents(pos, faces, uv, pos)
    return TraceObject.mesh("sphere", pos, faces, normals=pos, tangents=t, uvs=uv)


def camera(eye=(0.0, 0.3, 4.0)):
    return Camera.from_spec({"eye": list(eye), "target": [0.0, 0.0, 0.0], "up": [0.0, 1.0, 0.0],
                             "fov_deg": 32.0, "width": SIZE, "height": SIZE})


def traced_uv_derivatives(cam, tracer, centre, h=0.02):
    """Central differences of the traced UVs over ±h pixel in x and y; and the pixels whose
    four rays hit the centre ray's triangle (a difference across a mesh edge is no
    derivative)."""
    def at(ox, oy):
        g = tracer.trace(*cam.rays(offset=(0.5 + ox, 0.5 + oy)))
        return g.uv.astype(float), g.hit & (g.triangle_id == centre.triangle_id)
    (xp, hxp), (xm, hxm) = at(h, 0), at(-h, 0)
    (yp, hyp), (ym, hym) = at(0, h), at(0, -h)
    fx, fy = (xp - xm) / (2 * h), (yp - ym) / (2 * h)
    return np.concatenate([fx, fy], -1), hxp & hxm & hyp & hym


@pytest.mark.parametrize("kind", ["mesh", "analytic"])
def test_sphere_footprint_matches_traced_finite_differences(kind):
    """Per pixel the 2×2 UV Jacobian of footprint.py within 0.5 % (of its norm) of the traced
    UVs' central differences at a 0.01-pixel step and within 1 % at the render's one-pixel step,
    so the MIP level within 0.015 (away from the u seam, the poles' fans and the silhouette;
    views up to 73° from the normal)."""
    ob = uv_sphere(repeat=(0.913, 0.4565)) if kind == "mesh" else TraceObject.sphere(
        "sphere", (0.0, 0.0, 0.0), 1.0)
    cam = camera()
    tr = Tracer([ob])
    gb = tr.trace(*cam.rays())
    duv = uv_derivatives(cam, gb).astype(float)
    d0 = uv_derivatives(cam, gb, step=0.01).astype(float) / 0.01
    fd, ok = traced_uv_derivatives(cam, tr, gb)
    ok &= gb.hit & (np.abs(fd[..., [0, 2]]).max(-1) < 0.2)          # not across the u seam
    pos = gb.position.astype(float)
    ok &= np.abs(pos[..., 1]) < 0.9                                  # not the poles' fans
    view_cos = np.einsum("...k,...k->...", gb.normal.astype(float), gb.view.astype(float))
    ok &= view_cos > 0.3                                             # not the silhouette
    assert ok.sum() > 0.5 * gb.hit.sum()
    a, a0, b = duv[ok], d0[ok], fd[ok]
    rel = lambda x, y: np.linalg.norm(x - y, axis=1) / np.linalg.norm(y, axis=1)  # noqa: E731
    assert rel(a0, b).max() < 0.005, rel(a0, b).max()
    assert rel(a, b).max() < 0.01, rel(a, b).max()
    lod_a, lod_b = mip_level(a, 256), mip_level(b, 256)
    assert np.abs(lod_a - lod_b).max() < 0.015
    # the footprint grows towards the silhouette (1/cos foreshortening), not at the centre
    c = SIZE // 2
    assert abs(mip_level(duv[c, c], 256) - mip_level(fd[c, c], 256)) < 0.01


def _noisy_map(side=16, seed=1, spread=0.5):
    rng = np.random.default_rng(seed)
    n = np.concatenate([rng.normal(0, spread, (side, side, 2)), np.ones((side, side, 1))], -1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)


def test_vmf_equals_normals_mip_at_the_finest_level_on_a_sphere():
    """Footprints of 1/8 pixel (render.supersample 8's sub-samples) on the UV sphere with a map
    whose neighbouring texels differ (bilinear means as short as ~0.8): both methods shade the
    unit bilinear normal, diffuse and specular, so they agree to float rounding."""
    from sgpipe.brdf import make_brdf
    from sgpipe.normalmap.pyramid import mean_normal_pyramid
    from sgpipe.normalmap.vmf import VMFSettings, fit_vmf_pyramid
    from sgpipe.render.envdata import EnvData
    from sgpipe.render.materials import Material, pack_materials
    from sgpipe.render.normalmap_data import (NormalMapData, NormalMapPyramid,
                                              attach_normalmaps)
    from sgpipe.render.renderer import Frame, Light, ObjectShading, Renderer

    side, s = 16, 40.0
    normals = _noisy_map(side)
    p = fit_vmf_pyramid(normals, VMFSettings(lobes=2))
    packed = NormalMapPyramid(p.alpha, p.alpha_r,
                              [m.astype(np.float32) for m in mean_normal_pyramid(normals)])
    ob = uv_sphere(repeat=(side * 0.5 / 16, side * 0.25 / 16))
    cam = camera()
    gb = Tracer([ob]).trace(*cam.rays())
    fr = Frame.from_gbuffer(gb)
    fr.duv = uv_derivatives(cam, gb, (0.5, 0.5), 1.0 / 8).reshape(-1, 4)[fr.index]
    assert (mip_level(fr.duv, side) < 0).all()          # every pixel at level 0
    m = Material.from_brdf("bp", make_brdf("blinn_phong", {"exponent": s, "kd": 0.5, "ks": 0.5}))
    light = Light("directional", tuple(np.array([0.55, 0.45, 0.70]) / math.sqrt(0.9050)),
                  (1.5, 1.5, 1.5))
    r = Renderer(env=EnvData.constant(0.0), materials=pack_materials([m]),
                 objects=[ObjectShading(0, normal_map=-1)], lights=[light])
    attach_normalmaps(r, NormalMapData.pack([packed], [s], 8))
    vmf, nmip = r.shade("vmf", fr), r.shade("normals_mip", fr)
    assert nmip.max() > 0.1
    np.testing.assert_allclose(vmf, nmip, rtol=2e-4, atol=1e-5 * nmip.max())
