"""Device layout of the Han07 normal-map pyramids (`<out>/normalmap/<map>/`, docs/HAN07.md) for
the `vmf`, `normals_mip` and `toksvig` kernels (kernels/include/nm_shade.h).

    data = NormalMapData.pack([per_object_pyramid_or_None, ...], exponents=[s, ...])
    buffers = data.device_buffers(ctx)    # nm_data, nm_levels, nm_info, nm_brdf

Layout (float4 `nm_data`): per map and level ℓ (side m) first the lobes, texel-major in image
rows (row 0 = v = 1) then lobe j: (α_j, α_j·r_j) — eq 24's linear textures, interpolated before
κ and μ are recovered — then the plain MIP of the normals (mean.xyz, 0) per texel.
`nm_levels` int4 per (map, level): (lobe offset, side, mean offset, 0). `nm_info` int4 per
scene object: (first level row, levels, lobes J, has map). `nm_brdf` float4 per object:
(Blinn–Phong exponent s, max taps along the footprint's major axis (1: isotropic), 0, 0)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput


@dataclass
class NormalMapPyramid:
    """One map's levels: α (m, m, J), α·r (m, m, J, 3) and the plain mean normal (m, m, 3)."""

    alpha: list
    alpha_r: list
    mean: list

    @classmethod
    def load(cls, nm_dir: Path, name: str) -> "NormalMapPyramid":
        from sgpipe.artifacts.normalmap import read_baselines, read_vmf
        v = read_vmf(nm_dir, name)
        b = read_baselines(nm_dir, name)
        if len(b["mean"]) != len(v.alpha):
            raise BadInput("vmf.npz and baselines.npz have different level counts",
                           file=Path(nm_dir) / name, key=f"normalmap.{name}")
        return cls(v.alpha, v.alpha_r, b["mean"])


@dataclass
class NormalMapData:
    data: np.ndarray      # (K, 4) float32
    levels: np.ndarray    # (L, 4) int32
    info: np.ndarray      # (objects, 4) int32
    brdf: np.ndarray      # (objects, 4) float32

    @classmethod
    def empty(cls, n_objects: int) -> "NormalMapData":
        return cls.pack([None] * max(n_objects, 1), [1.0] * max(n_objects, 1))

    @classmethod
    def pack(cls, pyramids: list, exponents: list, max_taps: int = 1) -> "NormalMapData":
        """Pack per-object pyramids (None: no map; the same object shares its rows)."""
        parts, levels, info, off = [], [], [], 0
        seen: dict[int, tuple] = {}
        for p in pyramids:
            if p is None:
                info.append((0, 0, 0, 0))
                continue
            if id(p) not in seen:
                first = len(levels)
                for a, ar, mean in zip(p.alpha, p.alpha_r, p.mean):
                    m, j = a.shape[0], a.shape[2]
                    lob = np.concatenate([np.asarray(a, np.float32)[..., None],
                                          np.asarray(ar, np.float32)], -1).reshape(-1, 4)
                    mn = np.zeros((m * m, 4), np.float32)
                    mn[:, :3] = np.asarray(mean, np.float32).reshape(-1, 3)
                    levels.append((off, m, off + len(lob), 0))
                    parts += [lob, mn]
                    off += len(lob) + len(mn)
                seen[id(p)] = (first, len(p.alpha), p.alpha[0].shape[2], 1)
            info.append(seen[id(p)])
        brdf = np.zeros((len(info), 4), np.float32)
        brdf[:, 0] = exponents
        brdf[:, 1] = max_taps
        data = np.concatenate(parts) if parts else np.zeros((1, 4), np.float32)
        return cls(data, np.asarray(levels or [(0, 1, 0, 0)], np.int32).reshape(-1, 4),
                   np.asarray(info, np.int32).reshape(-1, 4), brdf)

    def device_buffers(self, ctx) -> dict:
        """The kernels' `nm_*` parameters."""
        from sgpipe.render import opencl
        return dict(nm_data=opencl.to_device(ctx, self.data),
                    nm_levels=opencl.to_device(ctx, self.levels, dtype=np.int32),
                    nm_info=opencl.to_device(ctx, self.info, dtype=np.int32),
                    nm_brdf=opencl.to_device(ctx, self.brdf))


def load_normalmap_data(cfg, out_dir, specs) -> NormalMapData:
    """The pyramids of the scene's normal-mapped objects from `<out>/normalmap/index.json` and
    each object's Blinn–Phong exponent (its material `specs[k]`; other models are refused: eq 20
    is the closed form these kernels implement)."""
    exponents = [_blinn_phong_exponent(spec) for spec in specs]
    nm_dir = Path(out_dir) / "normalmap"
    index = nm_dir / "index.json"
    objs = cfg.scene.objects
    if any(o.normal_map is not None for o in objs) and not index.is_file():
        raise BadInput("normal-map pyramids not found: add a `normalmap:` section and run "
                       "`sgpipe precompute` (or `sgpipe run`) with the same --out",
                       file=index, key="normalmap")
    by_object = {}
    if index.is_file():
        for entry in json.loads(index.read_text())["maps"]:
            for name in entry["objects"]:
                by_object[name] = entry["name"]
    cache: dict = {}
    pyramids = []
    for k, o in enumerate(objs):
        if o.normal_map is None:
            pyramids.append(None)
            continue
        name = by_object.get(o.name)
        if name is None:
            raise BadInput(f"object {o.name!r} has no normal-map pyramid in {index.name}",
                           file=index, key=f"scene.objects.{k}.normal_map")
        if name not in cache:
            cache[name] = NormalMapPyramid.load(nm_dir, name)
        pyramids.append(cache[name])
    taps = int(getattr(cfg.render, "normalmap_max_taps", 1))
    return NormalMapData.pack(pyramids, exponents, taps)


def _blinn_phong_exponent(spec) -> float:
    """The exponent s of a Blinn–Phong material spec without Fresnel (Lambert: no specular,
    s unused); other models are BadInput."""
    if spec.model == "lambert":
        return 1.0
    if spec.model != "blinn_phong":
        raise BadInput(f"the normal-map methods shade Blinn–Phong materials (Han07 eq 20) "
                       f"and Lambert; material {spec.name!r} is {spec.model!r}",
                       key=f"fit.materials.{spec.name}.model")
    params = dict(spec.params or {})
    if params.get("fresnel", "none") != "none":
        raise BadInput("the normal-map methods take fresnel: none",
                       key=f"fit.materials.{spec.name}.params.fresnel")
    return float(params.get("exponent", 100.0))


def attach_normalmaps(renderer, data: NormalMapData) -> None:
    """Upload `data` as the renderer's `nm_*` kernel parameters."""
    renderer.static.update(data.device_buffers(renderer.ctx))
