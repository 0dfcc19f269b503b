"""The fit stage's artifacts (`<out>/fit/`, docs/ARTIFACTS.md fit/): per material
`<material>/` the microfacet factor M_o (Wang09 eq 9), the NDF SG lobes (Wang09 eq 12/16), the
per-view vMF mixtures (Töral19 eq 3) and, for MERL, the tabulated model (Wang09 eq 13–14);
`materials.json` lists the materials in config order."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sgpipe.artifacts._common import cast, scalar, shaped
from sgpipe.errors import BadInput
from sgpipe.io import read_npz

MATERIALS_INDEX = "materials.json"
MICROFACET = "microfacet.npz"
MICROFACET_JSON = "microfacet.json"     # the same values with the kinds' names
NDF_SG = "ndf_sg.npz"
NDF_ASG = "ndf_asg.npz"                 # only with fit.ndf_sg.anisotropic: asg, anisotropic NDFs
NDF_SG_ROUGH = "ndf_sg_rough.npz"       # only for isotropic gltf_pbr: lobes per roughness
VIEW_GMM = "view_gmm.npz"
VIEW_GMM_TEXTURE = "view_gmm.exr"
#: Töral19's mixtures as published (`gmm_toral19`): 8 lobes, independent views, specular part
VIEW_GMM_TORAL19 = "view_gmm_toral19.npz"
#: isotropic gltf_pbr: the specular mixtures per roughness with Schlick F0 as a linear basis
VIEW_GMM_ROUGH = "view_gmm_rough.npz"
TABULATED = "tabulated.npz"
REPORT = "report.json"
ERROR_PLOT = "error_vs_lobes.png"
SLICES = "slices.png"

SHADOW_BINS = 90          # shadow_table: S(θ) at θ_k = (k + 0.5)·π/180
#: view_gmm.exr channels in order (OpenEXR sorts channels alphabetically; these names keep it)
VIEW_GMM_CHANNELS = ["R", "G", "B", "kappa", "mu_phi", "mu_theta"]

f32, i32 = np.float32, np.int32
NDF_SG_ARRAYS = {"axis": f32, "sharpness": f32, "amplitude": f32, "rel_l2": f32, "method": None}
NDF_ASG_ARRAYS = {"z": f32, "x": f32, "sharpness_x": f32, "sharpness_y": f32, "amplitude": f32,
                  "rel_l2": f32, "method": None}
NDF_SG_ROUGH_ARRAYS = {"alpha": f32, "sharpness": f32, "amplitude": f32, "rel_l2": f32,
                       "mid_rel_l2": f32, "mid_direct_rel_l2": f32}
VIEW_GMM_ARRAYS = {"view_theta": f32, "view_phi": f32, "view_dirs": f32, "alpha": f32,
                   "kappa": f32, "mu": f32, "mu_theta": f32, "mu_phi": f32, "albedo": f32,
                   "rel_l2": f32, "includes_diffuse": i32, "coherent": i32}
VIEW_GMM_ROUGH_ARRAYS = {"roughness": f32, "view_theta": f32, "view_phi": f32, "alpha": f32,
                         "kappa": f32, "mu_theta": f32, "mu_phi": f32, "rel_l2": f32,
                         "coherent": i32}
TABULATED_ARRAYS = {"ndf_theta_h": f32, "ndf_table": f32, "shadow_table": f32,
                    "shadow_pca_mean": f32, "shadow_pca_basis": f32, "shadow_pca_coeffs": f32,
                    "eta": f32}
_KIND_FIELDS = ("diffuse", "fresnel", "shadowing")     # int32 enums (their names: `*_kind`)


def material_file(material: str, name: str) -> str:
    """Path of one of a material's files relative to `<out>/fit/`."""
    return f"{material}/{name}"


def _key(material: str) -> str:
    return f"fit.materials.{material}"


# -- writers (the fit stage) ------------------------------------------------------------------
def write_materials_index(sink, names: list[str]) -> None:
    sink.write_json(MATERIALS_INDEX, {"materials": list(names)})


def write_microfacet(sink, material: str, params: dict) -> None:
    """`microfacet.npz` (numbers: float32, the kinds int32, `model` a string) and
    `microfacet.json` (the same with the kinds' names) from `BRDF.microfacet_params()`."""
    arrays = {}
    for k, v in params.items():
        if k.endswith("_kind"):
            continue
        if k == "model":
            arrays[k] = np.array(v)
        elif isinstance(v, (int, np.integer)) and k in _KIND_FIELDS:
            arrays[k] = np.int32(v)
        else:
            arrays[k] = np.asarray(v, f32)
    sink.write_npz(material_file(material, MICROFACET), arrays)
    sink.write_json(material_file(material, MICROFACET_JSON), params)


def write_ndf_sg(sink, material: str, arrays: dict) -> None:
    """`ndf_sg.npz`: axis (L, 3), sharpness (L,), amplitude (L,), rel_l2, method (L may be 0)."""
    sink.write_npz(material_file(material, NDF_SG), cast(arrays, NDF_SG_ARRAYS, NDF_SG))


def write_ndf_asg(sink, material: str, arrays: dict) -> None:
    """`ndf_asg.npz`: z (L, 3), x (L, 3), sharpness_x (L,), sharpness_y (L,), amplitude (L,),
    rel_l2, method — D(h) ≈ Σ_l c_l max(h·z_l, 0) e^{−λ_l (h·x_l)² − μ_l (h·y_l)²} (Xu13 eq 4)."""
    sink.write_npz(material_file(material, NDF_ASG), cast(arrays, NDF_ASG_ARRAYS, NDF_ASG))


def write_ndf_sg_rough(sink, material: str, arrays: dict) -> None:
    """`ndf_sg_rough.npz`: the NDF's SG lobes about +z per roughness, α (R,) uniform in ln α,
    sharpness (R, K), amplitude (R, K), each entry's rel_l2 (R,), and the error of the lobes
    interpolated at each cell's mid α (mid_rel_l2) beside a direct fit there (R − 1,)."""
    sink.write_npz(material_file(material, NDF_SG_ROUGH),
                   cast(arrays, NDF_SG_ROUGH_ARRAYS, NDF_SG_ROUGH))


def write_tabulated(sink, material: str, arrays: dict) -> None:
    """`tabulated.npz` (MERL materials): NDF and shadowing tables, shadowing PCA, η."""
    sink.write_npz(material_file(material, TABULATED), cast(arrays, TABULATED_ARRAYS, TABULATED))


def write_view_gmm_toral19(sink, material: str, arrays: dict) -> None:
    """`view_gmm_toral19.npz`: the arrays of `view_gmm.npz` for Töral19's published fit."""
    a = {k: np.asarray(v) for k, v in arrays.items()}
    sink.write_npz(material_file(material, VIEW_GMM_TORAL19),
                   cast(a, VIEW_GMM_ARRAYS, VIEW_GMM_TORAL19))


def write_view_gmm_rough(sink, material: str, arrays: dict) -> None:
    """`view_gmm_rough.npz`: roughness (R,) and per entry the arrays of `view_gmm.npz` (alpha
    (R, J, K, 3) in the F0 basis of fit.view_gmm_rough, kappa / mu_theta / mu_phi (R, J, K),
    rel_l2 (R, J))."""
    a = {k: np.asarray(v) for k, v in arrays.items()}
    sink.write_npz(material_file(material, VIEW_GMM_ROUGH),
                   cast(a, VIEW_GMM_ROUGH_ARRAYS, VIEW_GMM_ROUGH))


def write_view_gmm(sink, material: str, arrays: dict, *, view_theta_max: float) -> None:
    """`view_gmm.npz` (float32, flags int32) and the same data as the `view_gmm.exr` texture:
    row t, column p·K + k holds view j = t·Nφ + p, lobe k (channels VIEW_GMM_CHANNELS). The
    texture and its preview are made from `arrays` as given (the fit's float64 values)."""
    a = {k: np.asarray(v) for k, v in arrays.items()}
    sink.write_npz(material_file(material, VIEW_GMM), cast(a, VIEW_GMM_ARRAYS, VIEW_GMM))
    n_t, n_p = len(a["view_theta"]), len(a["view_phi"])
    k = a["alpha"].shape[1]
    tex = np.concatenate([a["alpha"], a["kappa"][..., None], a["mu_phi"][..., None],
                          a["mu_theta"][..., None]], axis=-1).reshape(n_t, n_p * k, 6)
    sink.write_exr(material_file(material, VIEW_GMM_TEXTURE), tex,
                   channel_names=VIEW_GMM_CHANNELS,
                   metadata={"lobes": k, "view_theta_max": float(view_theta_max),
                             "theta_count": n_t, "phi_count": n_p,
                             "coherent": int(a["coherent"]),
                             "includes_diffuse": int(a["includes_diffuse"])})


# -- readers (the renderer, tests) ------------------------------------------------------------
def read_materials_index(fit_dir: str | Path) -> list[str]:
    path = Path(fit_dir) / MATERIALS_INDEX
    if not path.is_file():
        raise BadInput("file not found", file=path, key="fit.materials")
    try:
        names = json.loads(path.read_text())["materials"]
    except (ValueError, KeyError, TypeError) as e:
        raise BadInput(f"not a materials index ({type(e).__name__}: {e})", file=path,
                       key="fit.materials") from None
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise BadInput("'materials' is not a list of names", file=path, key="fit.materials")
    return names


@dataclass
class Microfacet:
    """What evaluates M_o(i) = ks·g_scale·F(o·h)·G2(o,i)/(π (n·i)(n·o)) (Wang09 eq 9)."""

    kd: np.ndarray                      # (3,)
    ks: np.ndarray                      # (3,)
    g_scale: float
    diffuse: int
    fresnel: int
    shadowing: int
    f0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    eta: np.ndarray = field(default_factory=lambda: np.zeros(3))
    k: np.ndarray = field(default_factory=lambda: np.zeros(3))
    alpha_u: float = 0.0
    alpha_v: float = 0.0
    shadow_table: np.ndarray = field(default_factory=lambda: np.ones(SHADOW_BINS))


def read_microfacet(folder: str | Path, material: str) -> Microfacet:
    """`<folder>/microfacet.npz` of one material (`folder` = `<out>/fit/<material>`)."""
    path = Path(folder) / MICROFACET
    key = _key(material)
    z = read_npz(path, key=key, required=("kd", "ks", "g_scale", "diffuse", "fresnel",
                                          "shadowing"))
    opt = {k: shaped(z[k], (3,), k, path, key) for k in ("f0", "eta", "k") if k in z}
    opt.update({k: scalar(z[k]) for k in ("alpha_u", "alpha_v") if k in z})
    if "shadow_table" in z:
        opt["shadow_table"] = shaped(z["shadow_table"], (-1,), "shadow_table", path, key)
    return Microfacet(kd=shaped(z["kd"], (3,), "kd", path, key),
                      ks=shaped(z["ks"], (3,), "ks", path, key), g_scale=scalar(z["g_scale"]),
                      **{k: int(scalar(z[k])) for k in _KIND_FIELDS}, **opt)


@dataclass
class NdfLobes:
    """D(h) ≈ Σ_l amplitude_l e^{sharpness_l (h·axis_l − 1)} in the local frame."""

    axis: np.ndarray                    # (L, 3)
    sharpness: np.ndarray               # (L,)
    amplitude: np.ndarray               # (L,)


def read_ndf_sg(folder: str | Path, material: str) -> NdfLobes:
    path = Path(folder) / NDF_SG
    key = _key(material)
    z = read_npz(path, key=key, required=("axis", "sharpness", "amplitude"))
    lam = shaped(z["sharpness"], (-1,), "sharpness", path, key)
    return NdfLobes(axis=shaped(z["axis"], (len(lam), 3), "axis", path, key), sharpness=lam,
                    amplitude=shaped(z["amplitude"], (len(lam),), "amplitude", path, key))


@dataclass
class RoughLobes:
    """D_α(h) ≈ Σ_k amplitude[i, k] e^{sharpness[i, k] (h_z − 1)} at α = alpha[i]."""

    alpha: np.ndarray                   # (R,) uniform in ln α
    sharpness: np.ndarray               # (R, K)
    amplitude: np.ndarray               # (R, K)


def rough_lobes_at(alpha, sharpness, amplitude, a: float) -> tuple[np.ndarray, np.ndarray]:
    """(λ (K,), μ (K,)) of a roughness grid at α = a: ln λ and μ linear in ln α between its
    entries (the kernels' shading.h ndf_lobe); a clamped to the grid."""
    g = np.log(np.asarray(alpha, float))
    lam, mu = np.asarray(sharpness, float), np.asarray(amplitude, float)
    x = np.clip(np.log(a), g[0], g[-1])
    i = int(min(np.searchsorted(g, x, side="right") - 1, len(g) - 2))
    t = (x - g[i]) / (g[i + 1] - g[i])
    return (np.exp((1 - t) * np.log(lam[i]) + t * np.log(lam[i + 1])),
            (1 - t) * mu[i] + t * mu[i + 1])


def read_ndf_sg_rough(folder: str | Path, material: str) -> RoughLobes | None:
    """`ndf_sg_rough.npz` of one material, or None where the fit wrote none."""
    path = Path(folder) / NDF_SG_ROUGH
    if not path.is_file():
        return None
    key = _key(material)
    z = read_npz(path, key=key, required=("alpha", "sharpness", "amplitude"))
    alpha = shaped(z["alpha"], (-1,), "alpha", path, key)
    lam = z["sharpness"]
    if lam.ndim != 2 or len(alpha) < 2 or lam.shape[0] != len(alpha):
        raise BadInput(f"sharpness has shape {lam.shape}, expected ({len(alpha)}, K), K ≥ 1 "
                       "and at least 2 entries", file=path, key=key)
    a = np.asarray(alpha, float)
    if not (np.all(a > 0) and np.all(np.diff(a) > 0)):
        raise BadInput("alpha is not positive and increasing", file=path, key=key)
    return RoughLobes(alpha=alpha, sharpness=lam,
                      amplitude=shaped(z["amplitude"], lam.shape, "amplitude", path, key))


@dataclass
class NdfAsgLobes:
    """D(h) ≈ Σ_l amplitude_l max(h·z_l, 0) e^{−λ_l (h·x_l)² − μ_l (h·(z_l × x_l))²}."""

    z: np.ndarray                       # (L, 3)
    x: np.ndarray                       # (L, 3)
    sharpness_x: np.ndarray             # (L,) λ
    sharpness_y: np.ndarray             # (L,) μ
    amplitude: np.ndarray               # (L,)


def read_ndf_asg(folder: str | Path, material: str) -> NdfAsgLobes | None:
    """`ndf_asg.npz` of one material, or None where the fit wrote none."""
    path = Path(folder) / NDF_ASG
    if not path.is_file():
        return None
    key = _key(material)
    z = read_npz(path, key=key, required=("z", "x", "sharpness_x", "sharpness_y", "amplitude"))
    lam = shaped(z["sharpness_x"], (-1,), "sharpness_x", path, key)
    n = len(lam)
    return NdfAsgLobes(z=shaped(z["z"], (n, 3), "z", path, key),
                       x=shaped(z["x"], (n, 3), "x", path, key), sharpness_x=lam,
                       sharpness_y=shaped(z["sharpness_y"], (n,), "sharpness_y", path, key),
                       amplitude=shaped(z["amplitude"], (n,), "amplitude", path, key))


def read_view_gmm(folder: str | Path, material: str, *, name: str = VIEW_GMM) -> dict:
    """`view_gmm.npz` (or `name`: VIEW_GMM_TORAL19) arrays, their shapes checked: alpha
    (J, K, 3), kappa / mu_theta / mu_phi (J, K) with J = Nθ·Nφ."""
    path = Path(folder) / name
    key = _key(material)
    z = read_npz(path, key=key, required=("view_theta", "view_phi", "alpha", "kappa",
                                          "mu_theta", "mu_phi", "includes_diffuse",
                                          "coherent"))
    j = np.size(z["view_theta"]) * np.size(z["view_phi"])
    k = np.shape(z["alpha"])[1] if np.ndim(z["alpha"]) == 3 else -1
    shaped(z["alpha"], (j, k, 3), "alpha", path, key)
    for name in ("kappa", "mu_theta", "mu_phi"):
        shaped(z[name], (j, k), name, path, key)
    return z


def read_view_gmm_rough(folder: str | Path, material: str) -> dict | None:
    """`view_gmm_rough.npz` of one material, or None where the fit wrote none; shapes checked:
    roughness (R,) positive and increasing, alpha (R, J, K, 3), kappa / mu_* (R, J, K)."""
    path = Path(folder) / VIEW_GMM_ROUGH
    if not path.is_file():
        return None
    key = _key(material)
    z = read_npz(path, key=key, required=tuple(VIEW_GMM_ROUGH_ARRAYS))
    r = shaped(z["roughness"], (-1,), "roughness", path, key)
    j = np.size(z["view_theta"]) * np.size(z["view_phi"])
    k = np.shape(z["alpha"])[2] if np.ndim(z["alpha"]) == 4 else -1
    shaped(z["alpha"], (len(r), j, k, 3), "alpha", path, key)
    for name in ("kappa", "mu_theta", "mu_phi"):
        shaped(z[name], (len(r), j, k), name, path, key)
    if not (len(r) >= 1 and np.all(r > 0) and np.all(np.diff(r) > 0)):
        raise BadInput("roughness is not positive and increasing", file=path, key=key)
    return z


def read_tabulated(folder: str | Path, material: str) -> dict:
    return read_npz(Path(folder) / TABULATED, key=_key(material),
                    required=tuple(TABULATED_ARRAYS))
