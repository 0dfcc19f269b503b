"""Device layout of the Han07 normal-map pyramids (`<out>/normalmap/<map>/`, docs/HAN07.md) for
the normal-map kernels `vmf`, `normals_mip`, `toksvig`, `engine_bake`, `nm_sh`
(kernels/include/nm_shade.h).

    data = NormalMapData.pack([per_object_pyramid_or_None, ...], params=[s or α, ...],
                              models=[...])
    buffers = data.device_buffers(ctx)    # nm_data, nm_levels, nm_info, nm_brdf, nm_env_sh(8)

Layout (float4 `nm_data`): per map and level ℓ (side m) first the lobes, texel-major in image
rows (row 0 = v = 1) then lobe j: (α_j, α_j·r_j) — eq 24's linear textures, interpolated before
κ and μ are recovered — then, for a pyramid with colour features (eq 22), per texel and lobe j
two float4 (α_j·kd.rgb, α_j·ks.r), (α_j·ks.g, α_j·ks.b, 0, 0) — a glTF material's
(α_j·kd.rgb, α_j·F0.r), (α_j·F0.g, α_j·F0.b, α_j·ln roughness, 0) — at the lobe offset + m²·J,
then
the plain MIP of the normals (mean.xyz, |mean|) per texel, then the SH
NDF coefficients γ_lm (⌈K/4⌉ float4 per texel, K = (l* + 1)², zero-padded).
`nm_levels` int4 per (map, level): (lobe offset, side, mean offset, SH offset). `nm_info` int4
per scene object: (first level row, levels, lobes J, has map: 1 + 2·clamp u + 4·clamp v, a
glTF sampler's CLAMP_TO_EDGE per axis, else repeat). `nm_brdf` NM_BRDF_STRIDE floats
per object: Blinn–Phong exponent s or microfacet roughness (Beckmann, GGX α, Cook–Torrance m),
max taps along the footprint's major axis (1: isotropic), model (BRDF_MODELS), K (slots 0–3);
the pyramid's features (slot 12: 0 none, 1 kd / ks multipliers, 2 a glTF material's);
environment specular on (1/0, slot 13), footprint filter (0 trilinear, 1 box:
render.normalmap_footprint, slot 14), Han07 §5's l* (published_sh_order, slot 15); ρ̂_0 … ρ̂_16
of the specular function the SH method filters (eq 11, slots RHO0 …); a textured glTF
material's table of GGX ρ̂_l over α (`with_rho_table`: 1 + its float4 offset in `data`, slot
33, 0 none: its header (ln α_0, Δ ln α, entries, 0), then 5 float4 per entry); the rest 0.
`nm_env_sh` float4 per coefficient: the environment's radiance SH L_lm (world, l ≤ 2).
`nm_env_sh8` one zero row here: vmf_han07 binds Han07 §8's tables in its place
(Renderer.method_bindings, sgpipe.render.han07_env.environment_sh8)."""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput

#: Material models the kernels shade (nm_shade.h NM_LAMBERT … NM_MERL) → model code.
BRDF_MODELS = {"lambert": 0, "blinn_phong": 1, "beckmann": 2, "cook_torrance": 3, "ggx": 4,
               "gltf_pbr": 5, "merl": 6}
BRDF_STRIDE = 36     # nm_shade.h NM_BRDF_STRIDE
RHO0 = 16            # first ρ̂_l slot (nm_shade.h NM_RHO_SLOT)
ENV_SLOT = 13        # environment specular on
FEAT_SLOT = 12       # the pyramid carries colour features (nm_shade.h NM_FEAT_SLOT)
FOOT_SLOT = 14       # footprint filter (nm_shade.h NM_FOOT_SLOT): 0 trilinear, 1 box
LSTAR_SLOT = 15      # Han07 §5's l* of the material (published_sh_order; nm_shade.h NM_LSTAR_SLOT)
RHOTAB_SLOT = 33     # 1 + the float4 offset of a ρ̂ table over α in data (nm_shade.h), 0 none
#: the GGX ρ̂ table's roughness grid (ln α, α = r², r from glTF's floor 0.06 to 1) and size
RHO_TABLE_ALPHAS = 48
FOOTPRINTS = {"trilinear": 0, "box": 1}
SH_LMAX = 16         # l* ≤ 16 (nm_shade.h NM_MAX_SH4 = 73 float4)
SH_METHODS = {"nm_sh", "nm_sh_han07"}      # the methods that read the SH pyramid
VMF_METHODS = {"vmf", "vmf_han07"}         # ... and the vMF pyramid


@dataclass
class NormalMapPyramid:
    """One map's levels: α (m, m, J), α·r (m, m, J, 3), the plain mean normal (m, m, 3) and
    optionally the SH NDF coefficients γ_lm (m, m, K) and the lobes' colour features α·f
    (m, m, J, 6: kd.rgb, ks.rgb; Han07 eq 22)."""

    alpha: list
    alpha_r: list
    mean: list
    gamma: list | None = None
    alpha_f: list | None = None
    wrap: tuple = ("repeat", "repeat")      # per axis u, v: "repeat" or "clamp"
    gltf_features: bool = False             # alpha_f holds GLTF_FEATURE_NAMES (absolute)

    @classmethod
    def load(cls, nm_dir: Path, name: str, *, need_vmf: bool = True,
             need_sh: bool = False) -> "NormalMapPyramid":
        from sgpipe.artifacts.normalmap import SH, VMF, map_file, read_baselines, read_sh, read_vmf
        b = read_baselines(nm_dir, name)
        n = len(b["mean"])
        alpha_f, glf = None, False
        if need_vmf or (Path(nm_dir) / map_file(name, VMF)).is_file():
            from sgpipe.artifacts.normalmap import GLTF_FEATURE_NAMES
            v = read_vmf(nm_dir, name)
            alpha, alpha_r, alpha_f = v.alpha, v.alpha_r, v.alpha_f
            glf = alpha_f is not None and v.feature_names == GLTF_FEATURE_NAMES
        else:        # no vMF pyramid (normalmap.methods without vmf): zero lobes
            alpha = [np.zeros(m.shape[:2] + (0,), np.float32) for m in b["mean"]]
            alpha_r = [np.zeros(m.shape[:2] + (0, 3), np.float32) for m in b["mean"]]
        gamma = None
        if need_sh:
            if not (Path(nm_dir) / map_file(name, SH)).is_file():
                raise BadInput("method nm_sh needs the SH pyramid: add `sh` to normalmap.methods",
                               file=Path(nm_dir) / map_file(name, SH), key="normalmap.methods")
            gamma, lmax = read_sh(nm_dir, name)
            if lmax > SH_LMAX:
                raise BadInput(f"nm_sh renders SH orders up to {SH_LMAX}, got {lmax}",
                               file=Path(nm_dir) / map_file(name, SH), key="normalmap.sh_order")
        if len(alpha) != n or (gamma is not None and len(gamma) != n):
            raise BadInput("vmf.npz, sh.npz and baselines.npz have different level counts",
                           file=Path(nm_dir) / name, key=f"normalmap.{name}")
        return cls(alpha, alpha_r, b["mean"], gamma, alpha_f, gltf_features=glf)


@dataclass
class NormalMapData:
    data: np.ndarray      # (K, 4) float32
    levels: np.ndarray    # (L, 4) int32
    info: np.ndarray      # (objects, 4) int32
    brdf: np.ndarray      # (objects, BRDF_STRIDE) float32
    env_sh: np.ndarray    # (max(n, 1), 4) float32
    n_env_sh: int = 0

    @classmethod
    def empty(cls, n_objects: int) -> "NormalMapData":
        return cls.pack([None] * max(n_objects, 1), [1.0] * max(n_objects, 1))

    @classmethod
    def pack(cls, pyramids: list, params: list, max_taps: int = 1, models: list | None = None,
             rho_hat: list | None = None, footprint: str = "trilinear") -> "NormalMapData":
        """Pack per-object pyramids (None: no map; the same object shares its rows) with each
        object's BRDF parameter (Blinn–Phong s, or microfacet roughness), model code
        (default Blinn–Phong) and ρ̂_l of its specular function (nm_sh)."""
        parts, levels, info, off = [], [], [], 0
        seen: dict[int, tuple] = {}
        nsh = [0] * len(pyramids)
        feat = [0.0] * len(pyramids)
        for k, p in enumerate(pyramids):
            if p is None:
                info.append((0, 0, 0, 0))
                continue
            if id(p) not in seen:
                first = len(levels)
                for lv, (a, ar, mean) in enumerate(zip(p.alpha, p.alpha_r, p.mean)):
                    m = a.shape[0]
                    lob = np.concatenate([np.asarray(a, np.float32)[..., None],
                                          np.asarray(ar, np.float32)], -1).reshape(-1, 4)
                    if p.alpha_f is not None:     # α·features per lobe, two float4 each
                        af = np.zeros(a.shape + (8,), np.float32)
                        f = np.asarray(p.alpha_f[lv], np.float32)
                        af[..., :f.shape[-1]] = f
                        lob = np.concatenate([lob, af.reshape(-1, 4)])
                    mn = np.zeros((m * m, 4), np.float32)
                    mn[:, :3] = np.asarray(mean, np.float32).reshape(-1, 3)
                    mn[:, 3] = np.linalg.norm(mn[:, :3], axis=1)   # the bake's per-texel |n̄|
                    sh = np.zeros((0, 4), np.float32)
                    if p.gamma is not None:
                        g = np.asarray(p.gamma[lv], np.float32).reshape(m * m, -1)
                        k4 = -(-g.shape[1] // 4)
                        sh = np.zeros((m * m, 4 * k4), np.float32)
                        sh[:, :g.shape[1]] = g
                        sh = sh.reshape(-1, 4)
                    levels.append((off, m, off + len(lob), off + len(lob) + len(mn)))
                    parts += [lob, mn, sh]
                    off += len(lob) + len(mn) + len(sh)
                seen[id(p)] = (first, len(p.alpha), p.alpha[0].shape[2],
                               1 + 2 * (p.wrap[0] == "clamp") + 4 * (p.wrap[1] == "clamp"))
            info.append(seen[id(p)])
            if p.gamma is not None:
                nsh[k] = int(np.asarray(p.gamma[0]).shape[-1])
            feat[k] = 0.0 if p.alpha_f is None else (2.0 if p.gltf_features else 1.0)
        brdf = np.zeros((len(info), BRDF_STRIDE), np.float32)
        brdf[:, 0] = params
        brdf[:, 1] = max_taps
        brdf[:, 2] = models if models is not None else BRDF_MODELS["blinn_phong"]
        brdf[:, 3] = nsh
        brdf[:, FOOT_SLOT] = FOOTPRINTS[footprint]
        brdf[:, FEAT_SLOT] = feat
        name_of = {code: name for name, code in BRDF_MODELS.items()}
        brdf[:, LSTAR_SLOT] = [published_sh_order(name_of[int(c)], float(p))
                               for c, p in zip(brdf[:, 2], brdf[:, 0])]
        for k, rho in enumerate(rho_hat or []):
            if rho is not None:
                brdf[k, RHO0:RHO0 + len(rho)] = np.asarray(rho, np.float32)[:SH_LMAX + 1]
        data = np.concatenate(parts) if parts else np.zeros((1, 4), np.float32)
        if len(data) == 0:
            data = np.zeros((1, 4), np.float32)
        return cls(data, np.asarray(levels or [(0, 1, 0, 0)], np.int32).reshape(-1, 4),
                   np.asarray(info, np.int32).reshape(-1, 4), brdf, np.zeros((1, 4), np.float32))

    def with_rho_table(self, objects: list[bool]) -> "NormalMapData":
        """Append the GGX specular function's ρ̂_l (l ≤ SH_LMAX) on a grid of α (`rho_table`) to
        `data` for the `objects` whose material is textured glTF: nm_sh (eq 12) and vmf_han07
        (eq 26) read it at the pixel's (a lobe's) filtered roughness (nm_rho_at)."""
        if not any(objects):
            return self
        la, rows = rho_table()
        head = np.array([[la[0], la[1] - la[0], len(la), 0.0]], np.float32)
        body = np.zeros((len(la), 4 * 5), np.float32)         # NM_RHO_F4 float4 per entry
        body[:, :rows.shape[1]] = rows
        off = len(self.data)
        self.data = np.concatenate([self.data, head, body.reshape(-1, 4)])
        self.brdf[np.asarray(objects, bool), RHOTAB_SLOT] = off + 1
        return self

    def with_environment(self, light_sh: np.ndarray | None, specular: bool) -> "NormalMapData":
        """The environment's radiance SH (first 9 coefficients, world) and whether its
        specular part is shaded (no environment: skip the Γ_L lookups)."""
        if light_sh is not None:
            c = np.asarray(light_sh, np.float32)[:9]
            self.env_sh = np.zeros((max(len(c), 1), 4), np.float32)
            self.env_sh[:len(c), :3] = c
            self.n_env_sh = len(c)
        self.brdf[:, ENV_SLOT] = 1.0 if specular else 0.0
        return self

    def device_buffers(self, ctx) -> dict:
        """The kernels' `nm_*` parameters."""
        from sgpipe.render import opencl
        return dict(nm_data=opencl.to_device(ctx, self.data),
                    nm_levels=opencl.to_device(ctx, self.levels, dtype=np.int32),
                    nm_info=opencl.to_device(ctx, self.info, dtype=np.int32),
                    nm_brdf=opencl.to_device(ctx, self.brdf.reshape(-1)),
                    nm_env_sh=opencl.to_device(ctx, self.env_sh), n_env_sh=self.n_env_sh,
                    nm_env_sh8=opencl.to_device(ctx, np.zeros((1, 4), np.float32)))


def load_normalmap_data(cfg, out_dir, specs, textured: list[bool] | None = None,
                        fitted: list | None = None) -> NormalMapData:
    """The pyramids of the scene's normal-mapped objects from `<out>/normalmap/index.json`, each
    object's material (its `specs[k]`: Lambert, Blinn–Phong, Beckmann, Cook–Torrance, GGX,
    glTF metal-rough or measured (MERL); other models are refused: eq 20 / 21 are the closed
    forms these kernels implement, a measured material's fitted NDF lobes the SGs they
    convolve) and the environment (SH for nm_sh's diffuse term; specular through Γ_L when
    there is one). `textured`: per object, whether its material is a textured glTF one (ρ̂_l
    from the table over α, `with_rho_table`); `fitted`: per object, its render.materials
    Material (a measured material's lobes)."""
    fitted = fitted or [None] * len(specs)
    lobes = [material_lobe(spec, mat) for spec, mat in zip(specs, fitted)]
    nm_dir = Path(out_dir) / "normalmap"
    index = nm_dir / "index.json"
    objs = cfg.scene.objects
    methods = set(cfg.render.methods)
    from sgpipe.render.setup import normal_mapped
    mapped = normal_mapped(cfg)
    if any(mapped) and not index.is_file():
        raise BadInput("normal-map pyramids not found: add a `normalmap:` section and run "
                       "`sgpipe precompute` (or `sgpipe run`) with the same --out",
                       file=index, key="normalmap")
    by_object, wrap = {}, {}
    if index.is_file():
        for entry in json.loads(index.read_text())["maps"]:
            wrap[entry["name"]] = tuple(entry.get("wrap", ("repeat", "repeat")))
            for name in entry["objects"]:
                by_object[name] = entry["name"]
    cache: dict = {}
    pyramids = []
    for k, o in enumerate(objs):
        if not mapped[k]:
            pyramids.append(None)
            continue
        name = by_object.get(o.name)
        if name is None:
            raise BadInput(f"object {o.name!r} has no normal-map pyramid in {index.name}",
                           file=index, key=f"scene.objects.{k}.normal_map")
        if name not in cache:
            cache[name] = NormalMapPyramid.load(nm_dir, name,
                                                need_vmf=bool(methods & VMF_METHODS),
                                                need_sh=bool(methods & SH_METHODS))
            cache[name].wrap = wrap[name]
        pyramids.append(cache[name])
        if "nm_sh_han07" in methods:
            stored = int(round(math.sqrt(cache[name].gamma[0].shape[-1]))) - 1
            need = published_sh_order(*lobes[k])
            if stored < need:
                raise BadInput(f"nm_sh_han07 (Han07 §5: l* ≈ √(4s)) needs SH order {need} for "
                               f"object {o.name!r} ({lobes[k][0]} {lobes[k][1]:g}); its pyramid "
                               f"stores {stored}", key="normalmap.sh_order")
    taps = int(getattr(cfg.render, "normalmap_max_taps", 1))
    # ρ̂_l, l ≤ SH_LMAX, of every object: nm_sh reads l ≤ its SH order, vmf_han07 l ≤ 8 (eq 26)
    rho = [merl_sh_coeffs(mat, SH_LMAX) if model == "merl"
           else specular_sh_coeffs(model, param, SH_LMAX)
           for (model, param), mat in zip(lobes, fitted)]
    data = NormalMapData.pack(pyramids, [prm for _, prm in lobes], taps,
                              [BRDF_MODELS[mdl] for mdl, _ in lobes], rho,
                              footprint=cfg.render.normalmap_footprint)
    data = data.with_rho_table(textured or [])
    light_sh = None
    if cfg.envmap is not None:
        from sgpipe.artifacts.envmap import read_light_sh
        light_sh = np.asarray(read_light_sh(Path(out_dir) / "envmap")["coeffs"], np.float64)
    return data.with_environment(light_sh, cfg.envmap is not None)


@lru_cache(maxsize=1)
def rho_table() -> tuple[np.ndarray, np.ndarray]:
    """(ln α (RHO_TABLE_ALPHAS,), ρ̂_l (RHO_TABLE_ALPHAS, SH_LMAX + 1)) of the GGX specular
    function (specular_sh_coeffs) for α = r², r from glTF's floor to 1, uniform in ln α."""
    from sgpipe.brdf.models import GLTF_MIN_ROUGHNESS
    la = np.linspace(2.0 * math.log(GLTF_MIN_ROUGHNESS), 0.0, RHO_TABLE_ALPHAS)
    return la, np.array([specular_sh_coeffs("gltf_pbr", math.exp(x), SH_LMAX) for x in la])


def published_sh_order(model: str, param: float) -> int:
    """Han07 §5's l* ≈ √(4s), rounded up and at least Lambert's 2: s the Blinn–Phong exponent,
    or a microfacet roughness's equivalent exponent 2/α² − 2 (nm_shade_body.h,
    NM_PUB_SH_LSTAR)."""
    if model == "lambert":
        return 2
    s = param if model == "blinn_phong" else 2.0 / param ** 2 - 2.0
    return max(int(math.ceil(math.sqrt(4.0 * max(s, 0.0)) - 1e-4)), 2)


def material_lobe(spec, fitted=None) -> tuple[str, float]:
    """(model, parameter) of a material spec: Blinn–Phong exponent s, Beckmann α,
    Cook–Torrance m or GGX α (`ggx`; `gltf_pbr`: max(roughness, 0.06)²), isotropic (Blinn–Phong
    without Fresnel); Lambert: ('lambert', 1); a measured material (`merl`, its fitted
    Material `fitted`): the GGX α whose D has its D*'s curvature at the peak, 4(1 − α²)/α² =
    Σ μ_k λ_k / Σ μ_k (Han07 §5's l* from it, as from a GGX α)."""
    params = dict(spec.params or {})
    if spec.model == "lambert":
        return "lambert", 1.0
    if spec.model == "merl":
        key = f"fit.materials.{spec.name}.model"
        if fitted is None or len(fitted.lobe_lambda) == 0:
            raise BadInput(f"measured material {spec.name!r} has no fitted NDF lobes "
                           "(run `sgpipe fit`)", key=key)
        if len(fitted.asg_lambda) or np.any(np.abs(fitted.lobe_axis[:, 2] - 1.0) > 1e-6):
            raise BadInput(f"the normal-map methods shade isotropic measured materials; "
                           f"{spec.name!r} was fitted with anisotropic or tilted lobes", key=key)
        mu, lam = np.asarray(fitted.lobe_mu, float), np.asarray(fitted.lobe_lambda, float)
        curv = float(np.sum(mu * lam) / np.sum(mu))         # d ln D*/d(n·h) at the peak
        return "merl", math.sqrt(4.0 / (curv + 4.0))
    if spec.model not in BRDF_MODELS:
        raise BadInput(f"the normal-map methods shade Lambert, Blinn–Phong (Han07 eq 20), "
                       f"Beckmann, Cook–Torrance, GGX, glTF metal-rough (eq 21) and measured "
                       f"(MERL) materials; material {spec.name!r} is {spec.model!r}",
                       key=f"fit.materials.{spec.name}.model")
    if spec.model == "gltf_pbr":
        from sgpipe.brdf.models import GLTF_MIN_ROUGHNESS
        if float(params.get("anisotropy", 0.0)) != 0.0:
            raise BadInput("the normal-map methods shade isotropic glTF materials",
                           key=f"fit.materials.{spec.name}.params.anisotropy")
        return "gltf_pbr", max(float(params.get("roughness", 1.0)), GLTF_MIN_ROUGHNESS) ** 2
    if spec.model == "blinn_phong":
        if params.get("fresnel", "none") != "none":
            raise BadInput("the normal-map methods take fresnel: none for Blinn–Phong",
                           key=f"fit.materials.{spec.name}.params.fresnel")
        return "blinn_phong", float(params.get("exponent", 100.0))
    if spec.model in ("beckmann", "ggx"):
        if "alpha_u" in params or "alpha_v" in params:
            raise BadInput(f"the normal-map methods shade isotropic {spec.model} (alpha)",
                           key=f"fit.materials.{spec.name}.params.alpha_u")
        return spec.model, float(params.get("alpha", 0.1))
    return "cook_torrance", float(params.get("m", 0.2))


def specular_function(model: str, param: float):
    """f(u) with ρ_s·cos = ks·F·G·f(n·h)/(n·o) (Beckmann, Cook–Torrance) or ρ_s = ks f(n·h)
    (Blinn–Phong): the factor of the BRDF the SH method filters (eq 3, 11)."""
    if model == "blinn_phong":
        s = param
        return lambda u: (s + 2.0) / (8.0 * math.pi) * np.maximum(u, 0.0) ** s
    if model == "beckmann":
        from sgpipe.brdf.ndf import beckmann_ndf
        return lambda u: beckmann_ndf(u, param) / 4.0
    if model in ("ggx", "gltf_pbr"):
        a2 = param * param
        return lambda u: np.where(u > 0, a2 / (4.0 * math.pi * (u * u * (a2 - 1.0) + 1.0) ** 2),
                                  0.0)
    if model == "cook_torrance":
        m = param
        return lambda u: np.where(u > 0, np.exp(-(np.arccos(np.clip(u, -1, 1)) / m) ** 2), 0.0
                                  ) / math.pi
    return lambda u: np.zeros_like(np.asarray(u, float))


def merl_sh_coeffs(fitted, lmax: int) -> np.ndarray:
    """ρ̂_l, l ≤ lmax, of a measured material's D*(u) = Σ_k μ_k e^{λ_k(u − 1)} (u > 0), its
    fitted NDF lobes about the normal (the factor nm_merl_m leaves to eq 11 / 12; quadrature)."""
    from sgpipe.core.sh import zonal_coeffs
    mu, lam = np.asarray(fitted.lobe_mu, float), np.asarray(fitted.lobe_lambda, float)
    return zonal_coeffs(lambda u: np.where(u > 0.0, np.sum(
        mu * np.exp(lam * (u[..., None] - 1.0)), -1), 0.0), lmax)


def specular_sh_coeffs(model: str, param: float, lmax: int) -> np.ndarray:
    """ρ̂_l = 2π ∫ f(u) P_l(u) du, l ≤ lmax, of `specular_function` (eq 11, quadrature)."""
    from sgpipe.core.sh import zonal_coeffs
    return zonal_coeffs(specular_function(model, param), lmax)


def attach_normalmaps(renderer, data: NormalMapData) -> None:
    """Upload `data` as the renderer's `nm_*` kernel parameters."""
    renderer.static.update(data.device_buffers(renderer.ctx))
