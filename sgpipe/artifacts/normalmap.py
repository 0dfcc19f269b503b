"""The normalmap stage's artifacts (`<out>/normalmap/<map>/`, docs/HAN07.md "Artifacts"):
per normal map the vMF textures (`vmf.npz`, Han07 §7.3), the SH NDF pyramid (`sh.npz`, §5),
the single-lobe baselines (`baselines.npz`), each level set also as an EXR MIP atlas with a
PNG preview; `index.json` beside the maps names which objects use which map.

MIP atlas layout (EXR): level 0 (n × n) on the left, levels 1, 2, … stacked top to bottom in a
column of width n/2 on its right (level ℓ ≥ 1 at x = n, y = n(1 − 2^{1−ℓ})): an image of
3n/2 × n. Row 0 is the top of the texture (v = 1), as in the input map."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sgpipe.artifacts._common import scalar
from sgpipe.errors import BadInput
from sgpipe.io import read_npz

INDEX = "index.json"
VMF = "vmf.npz"
SH = "sh.npz"
BASELINES = "baselines.npz"
QUALITY = "quality.json"
PREVIEW_LEVELS = "preview_levels.png"
#: the vMF lobes' colour features (Han07 eq 22; `feature_names` in vmf.npz, in this order): the
#: render.material_textures multipliers of kd and ks
FEATURE_NAMES = ("kd.r", "kd.g", "kd.b", "ks.r", "ks.g", "ks.b")
#: a glTF material's features: the BRDF's linear parameters kd = (1 − m)c, F0 = lerp(0.04, c, m)
#: and ln roughness, its factors applied (render.setup.linear_parameters)
GLTF_FEATURE_NAMES = ("kd.r", "kd.g", "kd.b", "f0.r", "f0.g", "f0.b", "ln_roughness")


def map_file(name: str, f: str) -> str:
    """Path of a map's file relative to `<out>/normalmap/`."""
    return f"{name}/{f}"


def vmf_atlas_name(lobe: int) -> str:
    return f"vmf_lobe{lobe}.exr"


def atlas(levels: list[np.ndarray]) -> np.ndarray:
    """Pack a MIP chain (n, n, C), (n/2, n/2, C), … into the 3n/2 × n atlas (zeros elsewhere)."""
    n = levels[0].shape[0]
    c = levels[0].shape[2]
    out = np.zeros((n, n + max(n // 2, 1), c), np.float32)
    out[:, :n] = levels[0]
    for lev, a in enumerate(levels[1:], start=1):
        y = int(round(n * (1.0 - 2.0 ** (1 - lev))))
        m = a.shape[0]
        out[y:y + m, n:n + m] = a
    return out


def unpack_atlas(img: np.ndarray, n_levels: int) -> list[np.ndarray]:
    """Inverse of `atlas`."""
    n = img.shape[0]
    out = [img[:, :n]]
    for lev in range(1, n_levels):
        y = int(round(n * (1.0 - 2.0 ** (1 - lev))))
        m = n >> lev
        out.append(img[y:y + m, n:n + m])
    return out


def _vector_png(sink, name: str, levels: list[np.ndarray]) -> None:
    """8-bit preview of per-level vectors in [−1, 1]³ as (v + 1)/2 (a normal map's colours)."""
    img = atlas([np.asarray(v, np.float32) for v in levels])
    sink.write_png(name, np.round(np.clip(img * 0.5 + 0.5, 0, 1) * 255).astype(np.uint8),
                   already_8bit=True)


def _levels_arrays(prefix: str, levels: list[np.ndarray]) -> dict:
    return {f"{prefix}_{lev:02d}": np.asarray(a, np.float32) for lev, a in enumerate(levels)}


# -- writers (the normalmap stage) ------------------------------------------------------------
def write_vmf(sink, name: str, alpha: list, alpha_r: list, *, kappa_max: float,
              aligned: bool, alpha_f: list | None = None,
              feature_names: tuple = FEATURE_NAMES) -> None:
    """`vmf.npz`: alpha_LL (m, m, J) and alpha_r_LL (m, m, J, 3) float32 per level LL; one
    RGBA EXR atlas per lobe j (channels alpha, alpha_r.x/y/z: Algorithm 2's vMFTexture[j]).
    With features (Han07 eq 22): alpha_f_LL (m, m, J, F) and `feature_names`, one EXR
    atlas per lobe of α·f (`vmf_lobe<j>_features.exr`) and a PNG of the lobe's kd colour."""
    k_n = alpha[0].shape[2]
    extra = {} if alpha_f is None else {**_levels_arrays("alpha_f", alpha_f),
                                        "feature_names": np.array(feature_names)}
    sink.write_npz(map_file(name, VMF), {
        **_levels_arrays("alpha", alpha), **_levels_arrays("alpha_r", alpha_r),
        "levels": np.int32(len(alpha)), "lobes": np.int32(k_n),
        "kappa_max": np.float64(kappa_max), "aligned": np.int32(aligned), **extra})
    for j in range(k_n):
        tex = [np.concatenate([a[..., j:j + 1], ar[..., j, :]], -1) for a, ar in
               zip(alpha, alpha_r)]
        p = sink.write_exr(map_file(name, vmf_atlas_name(j)), atlas(tex), png=False,
                           channel_names=["alpha", "alpha_r.x", "alpha_r.y", "alpha_r.z"],
                           metadata={"normal_map": name, "lobe": j, "layout": "mip_atlas"})
        _vector_png(sink, map_file(name, Path(p).with_suffix(".png").name),
                    [ar[..., j, :] for ar in alpha_r])          # α·r: grey where empty
        if alpha_f is None:
            continue
        stem = Path(vmf_atlas_name(j)).stem + "_features"
        sink.write_exr(map_file(name, stem + ".exr"),
                       atlas([np.asarray(af[..., j, :], np.float32) for af in alpha_f]),
                       png=False,
                       channel_names=[f"alpha_f.{c}" for c in feature_names],
                       metadata={"normal_map": name, "lobe": j, "layout": "mip_atlas"})
        kd = [np.where(a[..., j:j + 1] > 0, af[..., j, :3], 0.0)
              / np.maximum(a[..., j:j + 1], 1e-30) for a, af in zip(alpha, alpha_f)]
        sink.write_png(map_file(name, stem + ".png"),     # the lobe's kd: black where empty
                       np.round(np.clip(atlas(kd), 0, 1) * 255).astype(np.uint8),
                       already_8bit=True)


def write_sh(sink, name: str, gamma: list, lmax: int) -> None:
    """`sh.npz`: gamma_LL (m, m, (l*+1)²) float32 (sgpipe.core.sh order); EXR atlas `sh_ndf.exr`
    with one channel per coefficient, named cKK_lLmM (KK = the index, zero-padded to 3 digits
    from l* = 10 on, so that EXR's sorted channel order is the coefficient order)."""
    sink.write_npz(map_file(name, SH), {**_levels_arrays("gamma", gamma),
                                        "levels": np.int32(len(gamma)),
                                        "lmax": np.int32(lmax)})
    width = 2 if (lmax + 1) ** 2 <= 100 else 3
    chans = [f"c{l * (l + 1) + m:0{width}d}_l{l}m{m:+d}" for l in range(lmax + 1)
             for m in range(-l, l + 1)]
    sink.write_exr(map_file(name, "sh_ndf.exr"), atlas(gamma), png=False, channel_names=chans,
                   metadata={"normal_map": name, "lmax": lmax, "layout": "mip_atlas"})
    if lmax >= 1:   # band 1 is √(3/4π)·(mean n_y, n_z, n_x): preview the mean normal
        c = np.sqrt(3.0 / (4.0 * np.pi))
        _vector_png(sink, map_file(name, "sh_ndf.png"),
                    [np.stack([g[..., 3], g[..., 1], g[..., 2]], -1) / c for g in gamma])
    else:
        sink.write_png(map_file(name, "sh_ndf.png"), atlas(gamma)[..., 0] * np.sqrt(np.pi))


def write_baselines(sink, name: str, *, mean: list, toksvig: list, kappa: list,
                    roughness: list, toksvig_exponent: float, engine_alpha: float) -> None:
    """`baselines.npz`: mean_LL (unnormalised mean normal), toksvig_LL, kappa_LL,
    roughness_LL per level; EXR atlases normals_mip.exr (normalised, signed xyz),
    toksvig.exr, engine_roughness.exr."""
    sink.write_npz(map_file(name, BASELINES), {
        **_levels_arrays("mean", mean), **_levels_arrays("toksvig", toksvig),
        **_levels_arrays("kappa", kappa), **_levels_arrays("roughness", roughness),
        "levels": np.int32(len(mean)), "toksvig_exponent": np.float64(toksvig_exponent),
        "engine_alpha": np.float64(engine_alpha)})
    unit = [m / np.maximum(np.linalg.norm(m, axis=-1, keepdims=True), 1e-30) for m in mean]
    meta = {"normal_map": name, "layout": "mip_atlas"}
    sink.write_exr(map_file(name, "normals_mip.exr"), atlas(unit), png=False,
                   channel_names=["n.x", "n.y", "n.z"], metadata=meta)
    _vector_png(sink, map_file(name, "normals_mip.png"), unit)
    sink.write_exr(map_file(name, "toksvig.exr"), atlas([t[..., None] for t in toksvig])[..., 0],
                   metadata={**meta, "exponent": toksvig_exponent})
    sink.write_exr(map_file(name, "engine_roughness.exr"),
                   atlas([r[..., None] for r in roughness])[..., 0],
                   metadata={**meta, "alpha": engine_alpha})


# -- readers (the render stage, tests) ----------------------------------------------------------
@dataclass
class VMFTextures:
    alpha: list       # per level (m, m, J) float32
    alpha_r: list     # per level (m, m, J, 3) float32
    kappa_max: float
    aligned: bool
    alpha_f: list | None = None    # per level (m, m, J, F) float32: α·features (eq 22)
    feature_names: tuple = FEATURE_NAMES


def _levels(z, prefix, n, path, key, tail):
    out = []
    for lev in range(n):
        k = f"{prefix}_{lev:02d}"
        if k not in z:
            raise BadInput(f"missing array {k}", file=path, key=key)
        a = np.asarray(z[k], np.float32)
        side = z[f"{prefix}_00"].shape[0] >> lev
        if a.shape[:2] != (side, side) or a.shape[2:] != tail:
            raise BadInput(f"{k} has shape {a.shape}, expected {(side, side) + tail}",
                           file=path, key=key)
        out.append(a)
    return out


def read_vmf(nm_dir: str | Path, name: str) -> VMFTextures:
    path = Path(nm_dir) / map_file(name, VMF)
    key = f"normalmap.{name}"
    z = read_npz(path, key=key, required=("levels", "lobes", "alpha_00", "alpha_r_00"))
    n, k = int(scalar(z["levels"])), int(scalar(z["lobes"]))
    alpha_f = None
    if "alpha_f_00" in z:
        names = tuple(str(x) for x in np.asarray(z.get("feature_names", [])).reshape(-1))
        if names not in (FEATURE_NAMES, GLTF_FEATURE_NAMES):
            raise BadInput(f"feature_names {list(names)}, expected {list(FEATURE_NAMES)} or "
                           f"{list(GLTF_FEATURE_NAMES)}", file=path, key=key)
        alpha_f = _levels(z, "alpha_f", n, path, key, (k, len(names)))
    return VMFTextures(_levels(z, "alpha", n, path, key, (k,)),
                       _levels(z, "alpha_r", n, path, key, (k, 3)),
                       scalar(z.get("kappa_max", 1e4)), bool(scalar(z.get("aligned", 1))),
                       alpha_f, names if alpha_f is not None else FEATURE_NAMES)


def read_sh(nm_dir: str | Path, name: str) -> tuple[list, int]:
    """(gamma per level, lmax)."""
    path = Path(nm_dir) / map_file(name, SH)
    key = f"normalmap.{name}"
    z = read_npz(path, key=key, required=("levels", "lmax", "gamma_00"))
    lmax = int(scalar(z["lmax"]))
    return _levels(z, "gamma", int(scalar(z["levels"])), path, key, ((lmax + 1) ** 2,)), lmax


def read_baselines(nm_dir: str | Path, name: str) -> dict:
    """{'mean', 'toksvig', 'kappa', 'roughness': per-level lists, 'toksvig_exponent',
    'engine_alpha'}."""
    path = Path(nm_dir) / map_file(name, BASELINES)
    key = f"normalmap.{name}"
    z = read_npz(path, key=key, required=("levels", "mean_00"))
    n = int(scalar(z["levels"]))
    return {"mean": _levels(z, "mean", n, path, key, (3,)),
            "toksvig": _levels(z, "toksvig", n, path, key, ()),
            "kappa": _levels(z, "kappa", n, path, key, ()),
            "roughness": _levels(z, "roughness", n, path, key, ()),
            "toksvig_exponent": scalar(z["toksvig_exponent"]),
            "engine_alpha": scalar(z["engine_alpha"])}
