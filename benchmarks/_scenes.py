"""Scenes of benchmarks/bench_render.py: each returns (Renderer, Frame) ready to shade, built
through the same code as the render stage wherever the benchmark can afford it.

- `teapot_scene`: the `sg` / `fis` frame (teapot + floor meshes, synthetic env and PCA data).
- `normalmap_scene`: configs/normalmap_render.yaml (Han07, issue 16) through the real `fit` and
  `precompute` stages, `setup.build_scene` and the render stage's `supersampled_frames`.
- `transport_scene`: Green06's 512² speed scene (sgpipe.experiments.green06: the
  transport_floor.yaml ball at 10 242 vertices + the floor's 10 201, issue 17) with the real
  envmap stage, but mirror-lobe Gaussians instead of the transport stage's fit (see
  `write_mirror_transport`), written and read back through sgpipe.artifacts.transport, and
  synthetic SSDF data of the visibility stage's size (`synthetic_vis`).
"""

from __future__ import annotations

import contextlib
import importlib
import io
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def gltf_materials(textured: bool):
    """The glTF metal-rough material of the textured-asset frame, (materials, Textures): its
    fitted lobes (fit.ndf_sg auto), sg's energy tables and, textured, its roughness grid, a
    256² base colour of tiled paints and a metallic-roughness texture (roughness 0.05–0.8
    along u, metal bands in v)."""
    from sgpipe.brdf import make_brdf
    from sgpipe.brdf.ndf import GGXNDF
    from sgpipe.fit.ndf_sg import fit_ndf_sg
    from sgpipe.fit.ndf_sg_rough import fit_roughness_grid
    from sgpipe.render.materials import GltfFactors, Material
    from sgpipe.render.renderer import Textures
    params = {"base_color": [0.8, 0.6, 0.4], "metallic": 0.5, "roughness": 0.4}
    brdf = make_brdf("gltf_pbr", params)
    fit = fit_ndf_sg(brdf.ndf_model, n_lobes=0)
    m = Material.from_brdf("paint", brdf, lobes=[(a, lam, mu) for a, lam, mu in zip(
        fit.axis, fit.sharpness, fit.amplitude)])
    m.tabulate_ndf(brdf)
    tex = Textures()
    if textured:
        g = fit_roughness_grid(GGXNDF)
        from sgpipe.artifacts.fit import RoughLobes
        m.rough_grid = RoughLobes(g.alpha, g.sharpness, g.amplitude)
        u, v = np.meshgrid(np.arange(256) / 256, np.arange(256) / 256)
        paint = np.array([[0.8, 0.1, 0.05], [0.9, 0.6, 0.1], [0.05, 0.2, 0.8], [0.9, 0.9, 0.85]])
        base = paint[((u * 8).astype(int) + (v * 8).astype(int)) % 4]
        mr = np.stack([np.zeros_like(u), 0.05 + 0.75 * u, (v * 6).astype(int) % 2], -1)
        m.gltf = GltfFactors(np.ones(3), 1.0, 1.0, 0.0, tex.add(base, mip=True),
                             tex.add(mr, mip=True))
    from sgpipe.render.energy import attach_energy
    attach_energy([m])             # sg's energy tables, as the render stage attaches them
    return [m], tex


def teapot_scene(width=512, height=512, nv=48, res=32, env_lobes=8, gltf: str | None = None):
    """`sg` frame: teapot + floor of data_samples/, 1 NDF lobe, 8 environment SG lobes, `nv`
    PCA terms at `res`² SSDF resolution (`synthetic_vis`), one point light. `gltf`: both
    objects in one glTF metal-rough material instead, "uniform" or "textured"
    (`gltf_materials`). → (Renderer, TraceObjects, Camera)."""
    from sgpipe.brdf import make_brdf
    from sgpipe.io.mesh import build_mesh, _read_mesh_file
    from sgpipe.render.envdata import CubeChain, EnvData
    from sgpipe.render.materials import Material, pack_materials
    from sgpipe.render.renderer import Light, ObjectShading, Renderer
    from sgpipe.scene.camera import Camera
    from sgpipe.scene.gbuffer import TraceObject
    rng = np.random.default_rng(0)
    objs, shading = [], []
    teapot = make_brdf("cook_torrance", {"m": 0.2, "kd": [0.3, 0.1, 0.05], "ks": 1.0})
    mats = [Material.lambert("floor", [0.55, 0.52, 0.48]), Material.from_brdf("teapot", teapot)]
    mats[1].tabulate_ndf(teapot)            # exact D for fis
    for k, name in enumerate(("floor", "teapot")):
        P, F, N, UV = _read_mesh_file(ROOT / "data_samples" / f"{name}.obj", None)
        g = build_mesh(P, F, normals=N, uvs=UV, name=name)
        objs.append(TraceObject.mesh(name, g.positions, g.faces, normals=g.normals,
                                     tangents=g.tangents, uvs=g.uvs))
        shading.append(ObjectShading(k, vis=synthetic_vis(g.faces, len(g.positions), nv, res,
                                                          rng)))
    n = 64
    levels = [np.full((6 * (max(2, n >> k) + 2), max(2, n >> k) + 2, 3), 0.5 + 0.05 * k,
                      np.float32) for k in range(11)]
    mips = [np.full((6 * (m + 2), m + 2, 3), 0.5, np.float32) for m in (64, 32, 16, 8, 4, 2, 1)]
    axes = rng.normal(size=(env_lobes, 3))
    env = EnvData(pyramid=CubeChain.from_levels(levels),
                  lambdas=np.array([n * n / 4 / 2 ** k for k in range(11)], np.float32),
                  log_ratio=float(np.log(2)), mean=np.full(3, 0.5, np.float32),
                  mip=CubeChain.from_levels(mips),
                  light_axes=(axes / np.linalg.norm(axes, axis=1, keepdims=True)).astype(
                      np.float32),
                  light_lambda=rng.uniform(2, 40, env_lobes).astype(np.float32),
                  light_mu=rng.uniform(0.1, 2, (env_lobes, 3)).astype(np.float32))
    textures = None
    if gltf is not None:
        mats, textures = gltf_materials(gltf == "textured")
        shading = [ObjectShading(0, vis=s.vis) for s in shading]
    r = Renderer(env=env, materials=pack_materials(mats), objects=shading, textures=textures,
                 lights=[Light("point", (-2.0, 3.2, 1.6), (8, 8, 8), 0.05)])
    cam = Camera(eye=(2.4, 1.9, 3.3), target=(0, 0.42, 0), fov_deg=34, width=width,
                 height=height)
    return r, objs, cam


def _quiet_stages(cfg, work: Path, names) -> None:
    """Run sgpipe stages (their progress logs swallowed; a failure raises as it is)."""
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        for name in names:
            importlib.import_module(f"sgpipe.stages.{name}").run(cfg, work)


def _frame(cfg, bundle, footprints: bool):
    """The render stage's G-buffer → Frame path (pixel centres, supersample 1)."""
    from sgpipe.scene.camera import Camera
    from sgpipe.scene.gbuffer import Tracer
    from sgpipe.stages.render import supersampled_frames
    cam = Camera.from_spec(cfg.render.camera)
    tracer = Tracer(bundle.objects)
    gb = tracer.trace(*cam.rays())
    ((fr, _),) = supersampled_frames(cam, tracer, bundle, 1, False, centre=gb,
                                     footprints=footprints)
    return fr


#: Han07 full-frame variant: the plane ×8 (48 × 48, its UVs repeated 8×: the same texels per
#: unit length), the camera 1.9 above it looking 20° down, so that the frame's top row meets
#: the plane 5° below the horizon: every pixel is shaded, near texels magnified, far ones
#: minified along the view (the anisotropic footprint's 8 taps).
NORMALMAP_FULL_FRAME = ["scene.objects.0.scale=8", "scene.objects.0.uv_repeat=[8, 8]",
                        "render.camera.eye=[0, 1.9, 7]", "render.camera.target=[0, 0, 1.78]",
                        "render.camera.fov_deg=30"]


def normalmap_scene(work: Path, size: int = 512, extra: list[str] = ()):
    """configs/normalmap_render.yaml (grooves normal map on the floor plane, Blinn–Phong s 60,
    4 vMF lobes, one point light, anisotropic footprint up to 8 taps) at size², `vmf` only:
    the real fit and normal-map precompute stages into `work`, the render stage's scene setup
    and G-buffer with texture footprints. → (Renderer, Frame)."""
    from sgpipe.config.loader import load_config
    from sgpipe.render.methods import METHODS
    from sgpipe.render.setup import build_scene
    cfg = load_config(ROOT / "configs" / "normalmap_render.yaml",
                      [f"render.camera.width={size}", f"render.camera.height={size}",
                       "render.methods=[vmf]", "render.compare_to=null", *extra])
    _quiet_stages(cfg, work, ("fit", "precompute"))
    bundle = build_scene(cfg, work, [METHODS["vmf"]])
    return bundle.renderer, _frame(cfg, bundle, footprints=True)


#: Green06's render-speed run (sgpipe.experiments.green06, "floor_speed"): 10 242-vertex ball
#: (icosphere level 5) + the 10 201-vertex floor, 6×4² light texels, one sample per pixel.
GREEN06_SPEED = ["transport.cube_resolution=4", "transport.sphere_subdivisions=5",
                 "visibility.sphere_subdivisions=5", "render.supersample=1",
                 "envmap.environment=../data_samples/studio.exr", "transport.gaussians=1",
                 "render.methods=[transport]", "render.compare_to=null"]


def mirror_gaussians(brdf, g, min_cos: float, sigma: float):
    """One Gaussian per vertex of geometry `g` and each of the 92 views v, shaped as the fit
    of an unoccluded glossy vertex: μ the mirror direction 2(n·v)n − v, σ `sigma`, w the BRDF's
    specular lobe × cosine at μ (the lobe's peak); views with n·v ≤ min_cos weight zero, as the
    stage writes them. → mu (X, 92, 1, 3), sigma (X, 92, 1), w (X, 92, 1, 3)."""
    from sgpipe.core.sphere import to_local
    from sgpipe.transport.views import view_set
    views = view_set()[0]
    n, t, b = (np.asarray(a, float)[:, None, :] for a in (g.normals, g.tangents, g.bitangents))
    c = np.sum(n * views[None], -1)                                   # (X, 92)
    mu = 2.0 * c[..., None] * n - views[None]
    up = c > min_cos
    o = to_local(views[None], n, t, b)[up]                            # (A, 3)
    i = o * np.array([-1.0, -1.0, 1.0])                               # local mirror direction
    w = np.zeros(c.shape + (3,))
    w[up] = brdf.specular(o, i) * i[:, 2:3]
    return mu[:, :, None], np.full(c.shape + (1,), sigma), w[:, :, None]


def write_mirror_transport(cfg, work: Path, geoms, materials: list[str]) -> None:
    """`<work>/transport/` in the transport stage's format (StageRun + artifacts.write_object
    + compact.encode, as stages.transport writes it) from `mirror_gaussians` of each object's
    material (names of fit.materials) instead of the sampled-and-fitted transport (20k
    vertices take minutes to fit); a diffuse-only material gets zero Gaussians, as the stage
    writes it. σ = the fit's lower bound
    transport.sigma_min (resolved for the light cube), where the fit put ≥ 90 % of the ball's
    Gaussians in green06's speed run; SH transfer: unshadowed (the clamped cosine's SH)."""
    from sgpipe.artifacts import transport as artifacts
    from sgpipe.brdf import brdf_from_spec
    from sgpipe.stages.base import StageRun
    from sgpipe.stages.transport import _material
    from sgpipe.transport import compact
    from sgpipe.transport.sh_transfer import clamped_cosine_sh
    from sgpipe.transport.views import N_VIEWS
    t = cfg.transport
    lo, hi = np.radians(t.sigma_min_resolved_deg()), np.radians(t.sigma_max_deg)
    min_cos = float(np.sin(np.radians(t.min_view_elevation_deg)))
    specs = {m.name: m for m in cfg.fit.materials}
    with contextlib.redirect_stderr(io.StringIO()), StageRun(
            cfg, work, "transport", params={"synthetic": "mirror lobes (benchmarks/_scenes)",
                                            "materials": materials}, force=True) as run:
        for k, (g, name) in enumerate(zip(geoms, materials)):
            brdf, mat = brdf_from_spec(specs[name]), specs[name]
            if brdf.has_specular:
                mu, sigma, w = mirror_gaussians(brdf, g, min_cos, lo)
            else:
                x = (len(g.positions), N_VIEWS, 1)
                mu, sigma, w = np.zeros(x + (3,)), np.zeros(x), np.zeros(x + (3,))
            artifacts.write_object(run, g.name, packed=compact.encode(mu, sigma, w, lo, hi),
                                   cube_resolution=t.cube_resolution, gaussians=1,
                                   sh=clamped_cosine_sh(g.normals),
                                   diffuse_rgb=_material(cfg, k, mat.name)[3],
                                   positions=g.positions, normals=g.normals, faces=g.faces)


def synthetic_vis(faces, n_vertices: int, nv: int, res: int, rng):
    """SSDF PCA data of the visibility stage's size (`nv` terms at `res`²) on a mesh, with
    synthetic values: the kernels' cost does not depend on them."""
    from sgpipe.render.renderer import VisObject
    return VisObject(faces=np.asarray(faces, np.int32),
                     coeffs=rng.normal(0, 0.3, (n_vertices, nv)).astype(np.float32),
                     mean=np.full((res, res), 0.8, np.float32),
                     basis=rng.normal(0, 1.0 / res, (nv, res, res)).astype(np.float32))


def transport_scene(work: Path, size: int = 512, glossy_floor: bool = False,
                    extra: list[str] = ()):
    """Green06's speed scene at size² (configs/transport_floor.yaml + `GREEN06_SPEED`): the
    real envmap stage (studio map) into `work`, `write_mirror_transport` (the floor Lambert as
    in green06, or with the ball's GGX lobes: every vertex glossy), per object its material
    and SSDF data of the config's visibility size on the transport mesh (`synthetic_vis`; the
    visibility stage of 20k vertices takes minutes), the render stage's G-buffer (analytic
    ball, its icosphere reached by the proxy rays) and `attach_transport`.
    → (Renderer, Frame, vertices)."""
    from sgpipe.config.loader import load_config
    from sgpipe.io.mesh import load_scene
    from sgpipe.render.envdata import EnvData
    from sgpipe.render.materials import Material, pack_materials
    from sgpipe.render.renderer import ObjectShading, Renderer
    from sgpipe.render.scene import load_trace_objects
    from sgpipe.render.setup import (SceneBundle, environment_scale, lights_of, material_brdf,
                                     object_material_specs)
    from sgpipe.render.transport_data import attach_transport
    from sgpipe.scene.gbuffer import TraceObject
    cfg = load_config(ROOT / "configs" / "transport_floor.yaml",
                      [*GREEN06_SPEED, f"render.camera.width={size}",
                       f"render.camera.height={size}", *extra])
    _quiet_stages(cfg, work, ("envmap",))
    geoms = load_scene(cfg.scene, sphere_subdivisions=cfg.transport.sphere_subdivisions)
    write_mirror_transport(cfg, work, geoms, ["ball", "ball" if glossy_floor else "floor"])
    specs = object_material_specs(cfg)
    rng = np.random.default_rng(0)
    v = cfg.visibility
    vis = [synthetic_vis(g.faces, len(g.positions), v.pca_terms, v.resolution, rng)
           for g in geoms]
    r = Renderer(env=EnvData.load(work / "envmap"),
                 materials=pack_materials([Material.from_brdf(s.name, material_brdf(s))
                                           for s in specs]),
                 objects=[ObjectShading(k, vis=x) for k, x in enumerate(vis)],
                 lights=lights_of(cfg.render), env_scale=environment_scale(cfg),
                 fh_mode=cfg.render.fh)
    r.rotate_environment(cfg.render.environment_rotation.matrix())
    proxies = [TraceObject.mesh(o.name, g.positions, g.faces) if o.sphere_radius is not None
               else None for o, g in zip(cfg.scene.objects, geoms)]
    bundle = SceneBundle(r, load_trace_objects(cfg, None), proxies, None)
    attach_transport(r, cfg, work, vis)
    return r, _frame(cfg, bundle, footprints=False), sum(len(g.positions) for g in geoms)
