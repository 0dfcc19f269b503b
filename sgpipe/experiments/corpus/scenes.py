"""The fidelity corpus: a fixed list of slots (shape × map × material family × normal map ×
light) whose parameters a seed draws — roughness, anisotropy, colours, lamp and sun layouts,
camera azimuth and elevation, minification.

Each slot draws from its own stream `default_rng([seed, slot index])`, so one slot's draw never
moves another's, and `scenes(seed, work)` writes the generated inputs under `work` and returns
plain config dicts (the schema validates them when they are measured).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np

from sgpipe.experiments.corpus import assets
from sgpipe.io.mesh import write_obj

ROOT = Path(__file__).resolve().parents[3]
DATA = ROOT / "data_samples"
NORMAL_MAPS = {"grooves": DATA / "grooves_normal.png", "bumps": DATA / "normal_map.png"}
NORMAL_MAP_SIZE = 256
#: the unfiltered methods, and those that filter the normal map (Han07)
UNFILTERED = ("sg", "gmm", "fis")
FILTERED = ("vmf", "nm_sh", "normals_mip", "toksvig", "engine_bake")
#: slots whose shapes have few enough vertices for Green06's per-vertex transport
TRANSPORT_SHAPES = ("sphere", "bowl", "pair", "ball_floor")
VISIBILITY = {"trace_resolution": 128, "resolution": 32, "pca_terms": 48,
              "sphere_subdivisions": 3, "report_vertices": 0, "preview_vertices": 0}
#: transport reads the frame's triangles from the visibility stage: the same tessellation
TRANSPORT = {"report_vertices": 0, "sphere_subdivisions": VISIBILITY["sphere_subdivisions"]}


@dataclasses.dataclass(frozen=True)
class Slot:
    """One corpus cell: what is fixed; the seed draws the rest."""
    shape: str                      # sphere, teapot, bowl, plane, grazing, nm_sphere, pair,
                                    # ball_floor
    env: str                        # lamps, sky, mixed, studio (data_samples), sky_sun (idem)
    material: str                   # a key of MATERIALS
    normal_map: str | None = None   # grooves, bumps, vgrooves
    minification: float = 1.0       # texels per pixel at the image centre (normal maps)
    light: str | None = None        # point, directional

    @property
    def key(self) -> str:
        parts = [self.shape, self.env, self.material]
        if self.normal_map:
            parts.append(f"{self.normal_map}{self.minification:g}x")
        if self.light:
            parts.append(self.light)
        return "-".join(parts)


SLOTS = (
    Slot("sphere", "lamps", "ggx_diffuse"),
    Slot("sphere", "lamps", "beckmann_aniso"),
    Slot("sphere", "sky", "beckmann"),
    Slot("sphere", "sky", "ggx_aniso_diffuse"),
    Slot("sphere", "studio", "ward"),
    Slot("sphere", "mixed", "ward_aniso"),
    Slot("sphere", "sky_sun", "ggx", light="point"),
    Slot("teapot", "lamps", "ggx_diffuse"),
    Slot("teapot", "sky", "beckmann_diffuse", light="directional"),
    Slot("teapot", "mixed", "ward"),
    Slot("bowl", "lamps", "beckmann"),
    Slot("bowl", "sky_low", "ggx_diffuse"),
    Slot("bowl", "studio", "ggx", light="point"),
    Slot("plane", "lamps", "ggx"),
    Slot("grazing", "sky", "beckmann"),
    Slot("grazing", "mixed", "ggx_diffuse", light="directional"),
    Slot("plane", "mixed", "nm_beckmann", "grooves", 1.0, "directional"),
    Slot("plane", "lamps", "nm_beckmann", "vgrooves", 4.0),
    Slot("plane", "studio", "nm_blinn_phong", "bumps", 16.0, "point"),
    Slot("plane", "sky", "nm_beckmann", "vgrooves", 64.0, "directional"),
    Slot("grazing", "sky", "nm_beckmann", "grooves", 4.0),
    Slot("grazing", "lamps", "nm_beckmann", "bumps", 1.0),
    Slot("nm_sphere", "lamps", "nm_beckmann", "bumps", 4.0),
    Slot("nm_sphere", "sky", "nm_blinn_phong", "vgrooves", 16.0),
    Slot("nm_sphere", "studio", "nm_beckmann", "grooves", 1.0, "directional"),
    Slot("grazing", "mixed", "nm_beckmann", "vgrooves", 16.0),
    # glossy neighbours: two spheres side by side, a ball on a floor of the same glossy material
    Slot("pair", "lamps", "ggx_sharp"),
    Slot("pair", "studio", "beckmann_diffuse"),
    Slot("ball_floor", "sky", "beckmann_diffuse"),
    Slot("ball_floor", "studio", "ggx_sharp"),
)


def _log_uniform(rng, lo, hi) -> float:
    return float(math.exp(rng.uniform(math.log(lo), math.log(hi))))


def _colour(rng, lo, hi) -> list[float]:
    return [round(float(x), 4) for x in rng.uniform(lo, hi, 3)]


def draw_material(family: str, rng: np.random.Generator) -> dict:
    """A material dict (fit.materials entry) of `family` with seeded parameters: microfacet α
    0.02–0.4 (log-uniform; `*_sharp` 0.03–0.08), anisotropy up to 20:1, a diffuse layer in the
    *_diffuse families; nm_* families are the models the normal-map methods shade (Beckmann,
    Blinn–Phong)."""
    none = {"fresnel": "none"}
    if family in ("ggx", "beckmann"):
        p = {"alpha": round(_log_uniform(rng, 0.02, 0.4), 4), "ks": 0.9, **none}
    elif family == "ggx_sharp":
        p = {"alpha": round(_log_uniform(rng, 0.03, 0.08), 4), "ks": 0.9, **none}
    elif family in ("ggx_diffuse", "beckmann_diffuse"):
        p = {"alpha": round(_log_uniform(rng, 0.04, 0.4), 4),
             "ks": round(float(rng.uniform(0.3, 0.8)), 3), "kd": _colour(rng, 0.02, 0.5), **none}
    elif family in ("beckmann_aniso", "ggx_aniso_diffuse", "ward_aniso"):
        au = _log_uniform(rng, 0.01, 0.08)
        av = min(0.4, au * float(rng.uniform(3.0, 20.0)))
        if rng.uniform() < 0.5:
            au, av = av, au
        p = {"alpha_u": round(au, 4), "alpha_v": round(av, 4), "ks": 0.9, **none}
        if family == "ggx_aniso_diffuse":
            p.update(ks=round(float(rng.uniform(0.3, 0.8)), 3), kd=_colour(rng, 0.02, 0.4))
    elif family == "ward":
        p = {"alpha": round(_log_uniform(rng, 0.05, 0.4), 4), "ks": 0.6,
             "kd": _colour(rng, 0.02, 0.3)}
    elif family == "nm_beckmann":
        p = {"alpha": round(_log_uniform(rng, 0.05, 0.3), 4), "ks": 0.8,
             "kd": _colour(rng, 0.02, 0.2), **none}
    elif family == "nm_blinn_phong":
        p = {"exponent": round(_log_uniform(rng, 20.0, 200.0), 2), "ks": 0.85,
             "kd": _colour(rng, 0.02, 0.2)}
    else:
        raise ValueError(f"unknown material family {family!r}")
    model = {"nm_beckmann": "beckmann", "nm_blinn_phong": "blinn_phong",
             "ward_aniso": "ward", "ggx_sharp": "ggx"}.get(family, family.split("_")[0])
    return {"name": "surface", "model": model, "params": _energy_conserving(model, p)}


def _energy_conserving(model: str, p: dict) -> dict:
    """`p` as drawn if the fit stage accepts it, else with its diffuse colour lowered (by 10 %
    steps) to an albedo ≤ 0.99: a drawn kd + ks can reflect more than it receives."""
    from sgpipe.brdf import make_brdf
    from sgpipe.stages.fit import ENERGY_LIMIT, energy_check_albedo
    albedo = lambda q: float(np.max(energy_check_albedo(make_brdf(model, q))))  # noqa: E731
    if "kd" not in p:
        return p
    a = albedo(p)
    if a <= ENERGY_LIMIT:
        return p
    while a > 0.99:
        p = {**p, "kd": [round(0.9 * c, 4) for c in p["kd"]]}
        a = albedo(p)
    return p


def _environment(slot: Slot, rng, work: Path, key: str, h: int) -> tuple[Path, float]:
    """(map path, environment_exposure): data_samples' maps as they are, generated ones (h × 2h)
    written under work/maps/."""
    if slot.env == "studio":
        return DATA / "studio.exr", -2.0
    if slot.env == "sky_sun":
        return DATA / "sky_sun.exr", -1.0
    from sgpipe.io.exr import write_exr
    path = work / "maps" / f"{key}.exr"
    if slot.env == "lamps":
        lamps = assets.draw_lamps(rng, int(rng.integers(2, 6)))
        img, exposure = assets.lamp_map(lamps, h, 2 * h), 0.0
    elif slot.env in ("sky", "sky_low"):
        sun = assets.draw_sun(rng, low=slot.env == "sky_low")
        img, exposure = assets.sky_sun_map(sun, h, 2 * h), -1.0
    else:
        img, exposure = assets.mixed_map(rng, h, 2 * h), -1.0
    path.parent.mkdir(parents=True, exist_ok=True)
    write_exr(path, img)
    return path, exposure


def _orbit(rng, target, distance, elev_lo, elev_hi, fov) -> dict:
    az = math.radians(rng.uniform(0.0, 360.0))
    el = math.radians(rng.uniform(elev_lo, elev_hi))
    eye = [target[0] + distance * math.cos(el) * math.sin(az),
           target[1] + distance * math.sin(el),
           target[2] + distance * math.cos(el) * math.cos(az)]
    return {"eye": [round(x, 5) for x in eye], "target": list(target), "fov_deg": fov}


def _neighbours(slot: Slot, rng, work: Path) -> tuple[list[dict], dict]:
    """(objects, camera) of the glossy-neighbour shapes: `pair`, two unit spheres 0.2 apart,
    each half-hidden from the other's horizon; `ball_floor`, a ball of radius 0.6 resting on a
    4 × 4 floor of 41² vertices (fine enough for per-vertex transport)."""
    if slot.shape == "pair":
        objs = [{"name": "surface", "sphere_radius": 1.0, "translate": [-1.1, 0.0, 0.0]},
                {"name": "neighbour", "sphere_radius": 1.0, "translate": [1.1, 0.0, 0.0]}]
        return objs, _orbit(rng, (0.0, 0.0, 0.0), 6.0, 0.0, 35.0, 40.0)
    path = work / "meshes" / "floor_grid.obj"
    if not path.is_file():
        v, f, n = assets.floor_grid_mesh()
        write_obj(path, v, f, normals=n)
    objs = [{"name": "surface", "sphere_radius": 0.6, "translate": [0.0, 0.6, 0.0]},
            {"name": "floor", "mesh": str(path)}]
    return objs, _orbit(rng, (0.0, 0.35, 0.0), 3.6, 20.0, 45.0, 40.0)


def _geometry(slot: Slot, rng, work: Path, size: int) -> tuple[dict, dict, bool]:
    """(object entry without material, camera, needs visibility)."""
    if slot.shape == "sphere":
        return ({"sphere_radius": 1.0}, _orbit(rng, (0.0, 0.0, 0.0), 4.0, -10.0, 40.0, 32.0),
                False)
    if slot.shape == "teapot":
        return ({"mesh": str(DATA / "teapot.obj")},
                _orbit(rng, (0.0, 0.42, 0.0), 3.3, 10.0, 40.0, 34.0), True)
    if slot.shape == "bowl":
        path = work / "meshes" / "bowl.obj"
        if not path.is_file():
            v, f, n = assets.bowl_mesh()
            write_obj(path, v, f, normals=n)
        return ({"mesh": str(path)}, _orbit(rng, (0.0, 0.45, 0.0), 3.6, 30.0, 60.0, 36.0),
                True)
    if slot.shape == "nm_sphere":   # sphere.obj: u = φ/2π, v = 1 − θ/π; equator texel = m px
        dist, fov = 4.0, 32.0
        pix = 2.0 * (dist - 1.0) * math.tan(math.radians(fov / 2)) / size
        ru = 2.0 * math.pi * slot.minification / (NORMAL_MAP_SIZE * pix)
        cam = _orbit(rng, (0.0, 0.0, 0.0), dist, -20.0, 20.0, fov)
        return ({"mesh": str(DATA / "sphere.obj"), "uv_repeat": [round(ru, 4),
                                                                 round(ru / 2, 4)]}, cam, False)
    # floor.obj: 6 × 6 at y = 0, vt over [0, 1]
    if slot.shape == "plane":       # head-on: the frame sees 2 tan(fov/2) d of it
        fov = 20.0
        d = float(rng.uniform(2.0, 3.0))
        pix = 2.0 * d * math.tan(math.radians(fov / 2)) / size
        az = math.radians(rng.uniform(0.0, 360.0))
        cam = {"eye": [0.0, round(d, 5), 0.0], "target": [0.0, 0.0, 0.0],
               "up": [round(math.sin(az), 5), 0.0, round(-math.cos(az), 5)], "fov_deg": fov}
    else:                           # grazing: 10–20° above the plane, 3.5 units away
        fov = 24.0
        el = math.radians(rng.uniform(10.0, 20.0))
        az = math.radians(rng.uniform(0.0, 360.0))
        dist = 3.5
        cam = {"eye": [round(dist * math.cos(el) * math.sin(az), 5),
                       round(dist * math.sin(el), 5),
                       round(dist * math.cos(el) * math.cos(az), 5)],
               "target": [0.0, 0.0, 0.0], "fov_deg": fov}
        # at the image centre a pixel spans dist · fov/size across and 1/sin(el) × that along
        pix = 2.0 * dist * math.tan(math.radians(fov / 2)) / size
    rep = 6.0 * slot.minification * pix ** -1 / NORMAL_MAP_SIZE if slot.normal_map else 1.0
    obj = {"mesh": str(DATA / "floor.obj")}
    if slot.normal_map:
        obj["uv_repeat"] = [round(rep, 4), round(rep, 4)]
    return obj, cam, False


def _normal_map(slot: Slot, rng, work: Path) -> Path | None:
    if slot.normal_map is None:
        return None
    if slot.normal_map in NORMAL_MAPS:
        return NORMAL_MAPS[slot.normal_map]
    slope = round(float(rng.uniform(20.0, 40.0)), 2)
    path = work / "normal_maps" / f"vgrooves_{slope:g}.exr"
    if not path.is_file():
        assets.write_normal_map(path, assets.vgroove_normals(NORMAL_MAP_SIZE, 8, slope))
    return path


def _light(slot: Slot, rng) -> list[dict]:
    if slot.light is None:
        return []
    if slot.light == "directional":
        d = assets.elevation_dir(rng.uniform(25.0, 75.0), rng.uniform(0.0, 360.0))
        return [{"type": "directional", "direction": [round(float(x), 5) for x in d],
                 "intensity": [round(float(rng.uniform(0.4, 1.2)), 4)] * 3, "radius": 0.0}]
    p = 4.0 * assets.elevation_dir(rng.uniform(25.0, 70.0), rng.uniform(0.0, 360.0))
    return [{"type": "point", "position": [round(float(x), 4) for x in p],
             "intensity": [round(float(rng.uniform(4.0, 12.0)), 3)] * 3, "radius": 0.0}]


def scenes(seed: int, work: Path, *, size: int = 96, spp: int = 256,
           only: list[str] | None = None, env_height: int = assets.ENV_H) -> list[dict]:
    """[{"key", "slot", "config" (raw dict), "methods", "material"}] of the corpus for `seed`;
    generated maps (env_height × 2 env_height), meshes and normal maps go under `work`.
    `only`: slot keys to keep."""
    work = Path(work)
    out = []
    for i, slot in enumerate(SLOTS):
        if only and slot.key not in only:
            continue
        rng = np.random.default_rng([int(seed), i])
        mat = draw_material(slot.material, rng)
        env, exposure = _environment(slot, rng, work, f"s{seed}_{i:02d}_{slot.env}", env_height)
        if slot.shape in ("pair", "ball_floor"):
            objs, cam = _neighbours(slot, rng, work)
            vis = True
            for o in objs:
                o["material"] = "surface"
        else:
            obj, cam, vis = _geometry(slot, rng, work, size)
            obj.update(name="surface", material="surface")
            objs = [obj]
        nmap = _normal_map(slot, rng, work)
        cam.update(width=size, height=size)
        if nmap is not None:
            objs[0]["normal_map"] = str(nmap)
        methods = list(UNFILTERED)
        if nmap is not None:
            methods += list(FILTERED)
        elif slot.shape in TRANSPORT_SHAPES:
            methods += ["transport", "transport_green06"]
        cfg = {"name": f"corpus_s{seed}_{slot.key}", "seed": int(seed),
               "scene": {"objects": objs},
               "fit": {"materials": [mat]},
               "envmap": {"environment": str(env)},
               "render": {"camera": cam, "methods": ["reference"], "spp": spp,
                          "environment_exposure": exposure, "preview_exposure": 0.0,
                          "lights": _light(slot, rng),
                          "reference_area_lights": False}}
        if vis or "transport" in methods:
            cfg["visibility"] = dict(VISIBILITY)
        if nmap is not None:
            cfg["normalmap"] = {}
        if "transport" in methods:
            cfg["transport"] = dict(TRANSPORT)
        out.append({"key": slot.key, "slot": slot, "index": i, "config": cfg,
                    "methods": methods, "material": mat})
    return out
