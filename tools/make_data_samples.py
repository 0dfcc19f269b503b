"""Regenerate every file in data_samples/ (deterministic: two runs give byte-identical files).

    .venv/bin/python tools/make_data_samples.py [--out data_samples]

Env maps: sample_envmaps.py; meshes: sample_meshes.py (teapot data: teapot_data.py). This file
holds the normal map, the JSON sidecar, the README and the driver.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import sample_envmaps as env  # noqa: E402
from canonical import fsum_channels, normalize3  # noqa: E402
import sample_gltf  # noqa: E402
import sample_meshes as meshes  # noqa: E402
import sample_normalmaps  # noqa: E402
import sample_readme  # noqa: E402
from sgpipe.io import read_exr, write_exr, write_png  # noqa: E402
from sgpipe.io.atomic import atomic_path  # noqa: E402

ENV_SIZE = (256, 512)  # (height, width)
WHITE_SIZE = (32, 64)
NORMAL_MAP_SIZE = 256
PREVIEW_EXPOSURE = {"sky_sun": 0.0, "studio": -2.0}


# ---------------------------------------------------------------- normal map

BUMP_GRID = 4          # 4 x 4 round bumps per tile
BUMP_RADIUS = 0.09     # in uv units
BUMP_HEIGHT = 0.04
RIPPLE = (0.006, 6, 3)  # amplitude, cycles along u, cycles along v


def bump_height(u: np.ndarray, v: np.ndarray):
    """Tileable height field on the uv torus and its analytic gradient (h, dh/du, dh/dv):
    BUMP_GRID^2 bumps A (1 - r^2/R^2)^2 (r < R) plus a ripple a sin(2 pi (k u + l v))."""
    amp, ku, kv = RIPPLE
    arg = 2.0 * np.pi * (ku * u + kv * v)
    h = amp * np.sin(arg)
    hu = amp * 2.0 * np.pi * ku * np.cos(arg)
    hv = amp * 2.0 * np.pi * kv * np.cos(arg)
    cell = 1.0 / BUMP_GRID
    du = (u % cell) - cell / 2  # offset from the nearest bump centre (bumps sit mid-cell)
    dv = (v % cell) - cell / 2
    s = (du * du + dv * dv) / BUMP_RADIUS ** 2
    inside = s < 1.0
    h = h + np.where(inside, BUMP_HEIGHT * (1.0 - s) ** 2, 0.0)
    dh_ds = np.where(inside, -2.0 * BUMP_HEIGHT * (1.0 - s), 0.0)
    hu = hu + dh_ds * 2.0 * du / BUMP_RADIUS ** 2
    hv = hv + dh_ds * 2.0 * dv / BUMP_RADIUS ** 2
    return h, hu, hv


def make_normal_map(res: int = NORMAL_MAP_SIZE):
    """(height (res, res), unit tangent-space normals (res, res, 3)) at texel centres; row 0 is
    v = 1 (top of the image, OBJ vt convention), n = normalize(-dh/du, -dh/dv, 1), z up."""
    c = (np.arange(res) + 0.5) / res
    u, v = np.meshgrid(c, c[::-1], indexing="xy")
    h, hu, hv = bump_height(u, v)
    n = np.stack([-hu, -hv, np.ones_like(h)], -1)
    return h, normalize3(n)


def encode_normals_8bit(n: np.ndarray) -> np.ndarray:
    """(n * 0.5 + 0.5) * 255, rounded, as uint8 (linear, no sRGB curve)."""
    return np.round((n * 0.5 + 0.5) * 255.0).astype(np.uint8)


# ---------------------------------------------------------------- sidecar helpers


def _r(x, nd: int = 9):
    """Round floats (scalars or arrays) for the JSON sidecar; keeps the file readable."""
    a = np.round(np.asarray(x, np.float64), nd) + 0.0   # + 0.0: no negative zeros
    return float(a) if a.ndim == 0 else [float(y) for y in a.ravel()]


def map_integrals(img: np.ndarray) -> dict:
    """Sum over texels of radiance times exact texel solid angle (and times exact integral of
    max(cos theta, 0) for the irradiance at normal +Y), per channel."""
    h, w = img.shape[:2]
    return {
        "power_rgb": _r(fsum_channels(img * env.texel_solid_angles(h, w)[..., None])),
        "irradiance_up_rgb": _r(fsum_channels(img * env.texel_cos_weights(h, w)[..., None])),
    }


def _write_env(out: Path, name: str, img: np.ndarray, what: str) -> np.ndarray:
    path = write_exr(out / f"{name}.exr", img, half=True,
                     metadata={"stage": "data_samples", "content": what})
    if name in PREVIEW_EXPOSURE:
        write_png(out / f"{name}.png", img, exposure=PREVIEW_EXPOSURE[name])
    return read_exr(path).astype(np.float64)  # the stored (float16) texels


def _write_text(path: Path, text: str) -> None:
    with atomic_path(path) as tmp:
        tmp.write_bytes(text.encode("utf-8"))


# ---------------------------------------------------------------- driver


def make_envmaps(out: Path) -> dict:
    h, w = ENV_SIZE
    sky, sky_sun = env.make_sky_sun(h, w)
    stored = _write_env(out, "sky_sun", sky_sun, "sky gradient + ground + sun")
    sky_q = sky.astype(np.float32).astype(np.float16).astype(np.float64)  # as OIIO stores it
    g = env.sun_geometry()
    omega = env.texel_solid_angles(h, w)[..., None]
    info = {"sky_sun.exr": {
        "size": [w, h], "half": True, **map_integrals(stored),
        "sun": {
            "direction": _r(g["direction"]), **{k: env.SUN[k] for k in
                                                ("elevation_deg", "phi_deg",
                                                 "angular_radius_deg")},
            "solid_angle_sr": _r(g["solid_angle_sr"], 12),
            "radiance_rgb": _r(g["radiance_rgb"]),
            "power_rgb": _r(g["power_rgb"]),
            "irradiance_facing_rgb": _r(g["irradiance_facing_rgb"]),
            "power_from_texels_rgb": _r(fsum_channels((stored - sky_q) * omega)),
            "note": "added on top of the sky; power = radiance * solid angle",
        },
        "sky": {**{k: list(v) if isinstance(v, tuple) else v for k, v in env.SKY.items()},
                "power_rgb": _r(fsum_channels(sky_q * omega))},
    }}
    studio, parts = env.make_studio(h, w)
    stored = _write_env(out, "studio", studio, "softboxes on a dim background")
    bg = np.asarray(env.STUDIO_BACKGROUND_RGB)
    boxes = []
    for box, part in zip(env.SOFTBOXES, parts):
        c, e1, e2 = env.softbox_frame(box)
        om = env.softbox_solid_angle(box)
        boxes.append({**{k: (list(v) if isinstance(v, tuple) else v) for k, v in box.items()},
                      "center": _r(c), "width_axis": _r(e1), "height_axis": _r(e2),
                      "solid_angle_sr": _r(om, 12),
                      "power_rgb": _r(om * np.asarray(box["radiance_rgb"])),
                      "power_supersampled_rgb": _r(fsum_channels(part * omega))})
    analytic = 4.0 * np.pi * bg + sum(env.softbox_solid_angle(b) * np.asarray(b["radiance_rgb"])
                                      for b in env.SOFTBOXES)
    info["studio.exr"] = {
        "size": [w, h], "half": True, **map_integrals(stored),
        "power_analytic_rgb": _r(analytic),
        "background": {"rgb": list(env.STUDIO_BACKGROUND_RGB), "profile": "rgb * (1 + 0.5 y)",
                       "power_rgb": _r(4.0 * np.pi * bg)},
        "softboxes": boxes,
    }
    stored = _write_env(out, "white", np.ones(WHITE_SIZE + (3,)), "constant 1 (furnace)")
    info["white.exr"] = {"size": [WHITE_SIZE[1], WHITE_SIZE[0]], "half": True,
                         **map_integrals(stored), "power_analytic": _r(4.0 * np.pi),
                         "irradiance_up_analytic": _r(np.pi)}
    return info


def make_meshes(out: Path) -> dict:
    info = {}
    v, f, n, uv = meshes.uv_sphere()
    meshes.write_obj(out / "sphere.obj", v, f, normals=n, uvs=uv,
                     header="sgpipe sample: unit UV sphere, lat-long vt (see README)")
    info["sphere.obj"] = {"vertices": len(v), "faces": len(f)}
    v, f, n, meta = meshes.teapot()
    meshes.write_obj(out / "teapot.obj", v, f, normals=n,
                     header="sgpipe sample: Utah teapot (Newell 1975 Bezier data, public domain)")
    info["teapot.obj"] = {"vertices": len(v), "faces": len(f), **meta,
                          "bounds": [_r(v.min(0), 6), _r(v.max(0), 6)]}
    v, f, n, uv = meshes.floor_plane()
    meshes.write_obj(out / "floor.obj", v, f, normals=n, uvs=uv,
                     header="sgpipe sample: 6 x 6 floor at y = 0, normal +Y")
    info["floor.obj"] = {"vertices": len(v), "faces": len(f)}
    return info


def make_gltf(out: Path) -> dict:
    """textured_ball.glb: the UV sphere with base-colour, metallic-roughness and normal
    textures (tools/sample_gltf.py); its normal texture is normal_map.png's bumps at 128²."""
    _, n = make_normal_map(sample_gltf.TEX_H)
    facts = sample_gltf.write_textured_ball(out / "textured_ball.glb", meshes.uv_sphere(),
                                            encode_normals_8bit(n))
    return {"textured_ball.glb": facts}


def make_normal_maps(out: Path) -> dict:
    h, n = make_normal_map()
    write_png(out / "normal_map.png", encode_normals_8bit(n), already_8bit=True)
    write_exr(out / "normal_map.exr", n * 0.5 + 0.5, half=True,
              metadata={"stage": "data_samples", "content": "tangent-space normals n*0.5+0.5"})
    write_exr(out / "bump_height.exr", h, metadata={"stage": "data_samples",
                                                    "content": "height in uv units"})
    return {"normal_map": {"size": [h.shape[1], h.shape[0]], "bump_grid": BUMP_GRID,
                           "bump_radius_uv": BUMP_RADIUS, "bump_height_uv": BUMP_HEIGHT,
                           "ripple_amplitude_cycles_u_v": list(RIPPLE)}}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=str(Path(__file__).resolve().parents[1] / "data_samples"),
                    help="output folder (default: the repository's data_samples/)")
    args = ap.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    info = {"definitions": {
        "power_rgb": "integral over the sphere of L dw = sum(texel * exact texel solid angle)",
        "irradiance_up_rgb": "integral of L max(cos theta, 0) dw: irradiance at normal +Y",
        "latlong": "CONVENTIONS: phi = 2 pi u, theta = pi v, d = (sin t sin p, cos t, -sin t cos p)",
    }}
    info.update(make_envmaps(out))
    _write_text(out / "env_info.json", json.dumps(info, indent=2, sort_keys=True) + "\n")
    facts = {**info, **make_meshes(out), **make_normal_maps(out)}
    facts.update(sample_normalmaps.make(out))   # Han07 sample: grooves_normal*.png
    facts.update(make_gltf(out))
    _write_text(out / "README.md", sample_readme.render(out, facts))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
