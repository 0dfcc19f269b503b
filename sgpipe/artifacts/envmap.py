"""The envmap stage's artifacts (`<out>/envmap/`, docs/ARTIFACTS.md envmap/): file names, the
bordered cube-strip layouts, the writers the stage calls and the readers of the renderer, of
the envmap package's reference loaders and of the tests.

Layout "cube6v_bB": an image (6·(n+2B), n+2B, 3), face f (OpenGL order) in rows
[f·(n+2B), (f+1)·(n+2B)), B border rings per face holding the quantity at their own
extended-plane direction (docs/ARTIFACTS.md "Cube strip layout").
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sgpipe.artifacts._common import read_rgb, scalar, shaped
from sgpipe.errors import BadInput
from sgpipe.io import read_exr, read_npz

KEY = "envmap"
PYRAMID_INDEX = "pyramid.npz"
MIP_INDEX = "mip.npz"
LIGHT_SG = "light_sg.npz"
LIGHT_SH = "light_sh.npz"
IRRADIANCE = "irradiance.exr"
RAW_LEVEL = "pyramid/raw.exr"     # the finest cubemap of the levels' content (λ → ∞ end)

SAMPLE_BORDER = 1   # "cube6v_b1": level_LL, raw.exr, mip/cube_MM (bilinear fetch)
COEF_BORDER = 2     # "cube6v_b2": coef_LL / slope_LL (cubic B-spline taps −1..+2 stay inside)


def level_name(level: int, kind: str = "level") -> str:
    """`pyramid/level_LL.exr` (V samples), `coef_LL` (B-spline of V), `slope_LL` (of m)."""
    return f"pyramid/{kind}_{level:02d}.exr"


def mip_name(level: int, kind: str = "cube") -> str:
    """`mip/cube_MM.exr` ("cube6v_b1") or `mip/dp_MM.exr` (dual paraboloid, (n, 2n, 3))."""
    return f"mip/{kind}_{level:02d}.exr"


def strip_shape(n: int, border: int) -> tuple[int, int, int]:
    """Shape of a "cube6v_bB" level of face resolution n."""
    return (6 * (n + 2 * border), n + 2 * border, 3)


def _offsets(images) -> np.ndarray:
    """Texel offsets of each image when concatenated row-major, plus the total."""
    return np.concatenate([[0], np.cumsum([v.shape[0] * v.shape[1] for v in images])]
                          ).astype(np.int64)


# -- Γ_L pyramid (Wang09 eq 34–35) ------------------------------------------------------------
@dataclass
class PyramidArtifacts:
    """The pyramid as stored: per level V samples ("cube6v_b1") and the cubic B-spline
    coefficients of V and of m = ∂ln Γ_L/∂ln λ ("cube6v_b2"), the point set beside the levels
    and the unfiltered map of their content."""

    lambdas: np.ndarray                   # (L,) strictly decreasing
    face_res: np.ndarray                  # (L,)
    ratio: float                          # λ_ℓ/λ_ℓ₊₁
    mean: np.ndarray                      # (3,) mean radiance (the λ → 0 limit)
    samples: list[np.ndarray]             # level_LL
    values: list[np.ndarray] | None = None   # coef_LL (None: a folder without them)
    slopes: list[np.ndarray] | None = None   # slope_LL
    raw: np.ndarray | None = None         # pyramid/raw.exr
    point_dirs: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    point_energy: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


def write_pyramid(sink, pyr: PyramidArtifacts) -> None:
    """`pyramid/{level,coef,slope}_LL.exr`, `pyramid/raw.exr` and `pyramid.npz`."""
    for l, (lam, n) in enumerate(zip(pyr.lambdas, pyr.face_res)):
        meta = {"lambda": float(lam), "level": l, "face_res": int(n), "normalized": 1}
        sink.write_exr(level_name(l), pyr.samples[l],
                       metadata={**meta, "quantity": "V", "border": SAMPLE_BORDER,
                                 "layout": "cube6v_b1", "basis": "samples"}, png=True)
        if pyr.values is None:
            continue
        b2 = {**meta, "border": COEF_BORDER, "layout": "cube6v_b2", "basis": "cubic_bspline"}
        sink.write_exr(level_name(l, "coef"), pyr.values[l], metadata={**b2, "quantity": "V"},
                       png=False)
        sink.write_exr(level_name(l, "slope"), pyr.slopes[l],
                       metadata={**b2, "quantity": "dlnG_dlnlambda"}, png=False)
    if pyr.raw is not None:
        sink.write_exr(RAW_LEVEL, pyr.raw,
                       metadata={"face_res": int(pyr.raw.shape[1] - 2 * SAMPLE_BORDER),
                                 "border": SAMPLE_BORDER, "layout": "cube6v_b1",
                                 "quantity": "L", "basis": "samples"}, png=False)
    index = {"lambdas": np.asarray(pyr.lambdas, np.float64),
             "face_res": np.asarray(pyr.face_res, np.int32),
             "offsets": _offsets(pyr.samples), "border": np.int32(SAMPLE_BORDER),
             "mean": np.asarray(pyr.mean, np.float64), "ratio": np.float64(pyr.ratio),
             "point_dirs": np.asarray(pyr.point_dirs, np.float64).reshape(-1, 3),
             "point_energy": np.asarray(pyr.point_energy, np.float64).reshape(-1, 3)}
    if pyr.values is not None:
        index.update(coef_offsets=_offsets(pyr.values), coef_border=np.int32(COEF_BORDER))
    sink.write_npz(PYRAMID_INDEX, index)


def read_pyramid(folder: str | Path, *, key: str = KEY) -> PyramidArtifacts:
    """`pyramid.npz` and its level images, every image checked against the index's face_res;
    coef/slope only when `coef_00.exr` exists (older folders, test environments)."""
    folder = Path(folder)
    path = folder / PYRAMID_INDEX
    idx = read_npz(path, required=("lambdas", "face_res", "mean"), key=key)
    lam = np.asarray(idx["lambdas"], np.float64).reshape(-1)
    fres = np.asarray(idx["face_res"], np.int64).reshape(-1)
    if len(fres) != len(lam) or not len(lam):
        raise BadInput(f"face_res has {len(fres)} levels, lambdas {len(lam)}", file=path,
                       key=key)

    def strips(kind: str, border: int) -> list[np.ndarray]:
        return [read_rgb(folder / level_name(l, kind), key, strip_shape(int(n), border),
                         f"{PYRAMID_INDEX} face_res {n}") for l, n in enumerate(fres)]
    values = slopes = raw = None
    if (folder / level_name(0, "coef")).is_file():
        values, slopes = strips("coef", COEF_BORDER), strips("slope", COEF_BORDER)
    if (folder / RAW_LEVEL).is_file():
        raw = read_rgb(folder / RAW_LEVEL, key)
        if raw.shape[0] != 6 * raw.shape[1] or raw.shape[1] <= 2 * SAMPLE_BORDER:
            raise BadInput(f"shape {raw.shape} is not a bordered cube strip",
                           file=folder / RAW_LEVEL, key=key)
    ratio = scalar(idx["ratio"]) if "ratio" in idx else (
        float(lam[0] / lam[1]) if len(lam) > 1 else 2.0)
    points = {k: shaped(idx[k], (-1, 3), k, path, key) for k in ("point_dirs", "point_energy")
              if k in idx}
    return PyramidArtifacts(lambdas=lam, face_res=fres, ratio=ratio,
                            mean=shaped(idx["mean"], (3,), "mean", path, key),
                            samples=strips("level", SAMPLE_BORDER), values=values,
                            slopes=slopes, raw=raw, **points)


# -- box MIP chains (Töral19 eq 6–11) -------------------------------------------------------
@dataclass
class MipArtifacts:
    """One stored MIP chain: kind "cube" ("cube6v_b1" levels, face res N/2^m) or "dp" ((n, 2n, 3)
    dual-paraboloid levels with paraboloid scale b)."""

    kind: str
    levels: list[np.ndarray]
    b: float = 1.0


def write_mip(sink, cube: list[np.ndarray], dp: list[np.ndarray], *, dp_b: float,
              coverage: float) -> None:
    """`mip/cube_MM.exr`, `mip/dp_MM.exr` and `mip.npz` (coverage: a of eq 7–8)."""
    cube_res = [lv.shape[1] - 2 * SAMPLE_BORDER for lv in cube]
    dp_res = [lv.shape[0] for lv in dp]
    for m, (img, n) in enumerate(zip(cube, cube_res)):
        sink.write_exr(mip_name(m, "cube"), img, metadata={
            "level": m, "face_res": n, "border": SAMPLE_BORDER, "layout": "cube6v_b1"}, png=True)
    for m, (img, n) in enumerate(zip(dp, dp_res)):
        sink.write_exr(mip_name(m, "dp"), img,
                       metadata={"level": m, "res": n, "b": dp_b, "layout": "dp2h"}, png=True)
    sink.write_npz(MIP_INDEX, {"cube_res": np.asarray(cube_res, np.int32),
                               "cube_offsets": _offsets(cube),
                               "dp_res": np.asarray(dp_res, np.int32), "dp_offsets": _offsets(dp),
                               "dp_b": np.float64(dp_b), "N": np.int32(cube_res[0]),
                               "coverage": np.float64(coverage)})


def read_mip(folder: str | Path, kind: str = "cube", *, key: str = KEY) -> MipArtifacts:
    """One MIP chain (`kind` "cube" or "dp"), every level checked against `mip.npz`."""
    folder = Path(folder)
    if kind not in ("cube", "dp"):
        raise ValueError(f"kind must be 'cube' or 'dp', got {kind!r}")
    need = ("cube_res",) if kind == "cube" else ("dp_res", "dp_b")
    idx = read_npz(folder / MIP_INDEX, required=need, key=key)
    levels = []
    for m, n in enumerate(np.asarray(idx[need[0]], np.int64).reshape(-1)):
        shape = strip_shape(int(n), SAMPLE_BORDER) if kind == "cube" else (n, 2 * n, 3)
        levels.append(read_rgb(folder / mip_name(m, kind), key, shape,
                               f"{MIP_INDEX} {need[0]} {n}"))
    return MipArtifacts(kind, levels, scalar(idx["dp_b"]) if kind == "dp" else 1.0)


# -- light fits (Wang09 §6, Green06 SH) -------------------------------------------------------
@dataclass
class SGLightArtifacts:
    """L*(ω) = Σ_k μ_k e^{λ_k(ω·p_k − 1)}: unit world axes p (K, 3), λ (K,), μ (K, 3)."""

    axes: np.ndarray
    sharpness: np.ndarray
    amplitude: np.ndarray


def write_light_sg(sink, *, axes, sharpness, amplitude, irradiance_rel_err,
                   irradiance_rel_err_eq40) -> None:
    """`light_sg.npz`; the errors: relative RMS of its irradiance (exact cosine / the eq 40
    cosine SG) against `irradiance.exr`, per channel."""
    f = np.float64
    sink.write_npz(LIGHT_SG, {"axes": np.asarray(axes, f), "sharpness": np.asarray(sharpness, f),
                              "amplitude": np.asarray(amplitude, f),
                              "irradiance_rel_err": np.asarray(irradiance_rel_err, f),
                              "irradiance_rel_err_eq40": np.asarray(irradiance_rel_err_eq40, f)})


def write_light_sh(sink, *, lmax: int, coeffs, irradiance_coeffs, irradiance_rel_err) -> None:
    """`light_sh.npz`: radiance and irradiance SH coefficients (n, 3), n = (lmax + 1)²."""
    f = np.float64
    sink.write_npz(LIGHT_SH, {"lmax": np.int32(lmax), "coeffs": np.asarray(coeffs, f),
                              "irradiance_coeffs": np.asarray(irradiance_coeffs, f),
                              "irradiance_rel_err": np.asarray(irradiance_rel_err, f)})


def read_light_sg(folder: str | Path, *, key: str = KEY) -> SGLightArtifacts:
    path = Path(folder) / LIGHT_SG
    z = read_npz(path, required=("axes", "sharpness", "amplitude"), key=key)
    lam = shaped(z["sharpness"], (-1,), "sharpness", path, key)
    k = len(lam)
    return SGLightArtifacts(shaped(z["axes"], (k, 3), "axes", path, key), lam,
                            shaped(z["amplitude"], (k, 3), "amplitude", path, key))


def read_light_sh(folder: str | Path, *, key: str = KEY) -> dict:
    """{"lmax", "coeffs" (n, 3), "irradiance_coeffs" (n, 3), ...} with n = (lmax + 1)²."""
    path = Path(folder) / LIGHT_SH
    z = read_npz(path, required=("lmax", "coeffs", "irradiance_coeffs"), key=key)
    n = (int(scalar(z["lmax"])) + 1) ** 2
    for k in ("coeffs", "irradiance_coeffs"):
        shaped(z[k], (n, 3), k, path, key)
    return z


def write_irradiance(sink, image: np.ndarray) -> None:
    """`irradiance.exr`: exact E(n) as a lat-long map of the normal."""
    sink.write_exr(IRRADIANCE, image, metadata={"quantity": "irradiance"})


def read_irradiance(folder: str | Path, *, key: str = KEY) -> np.ndarray:
    return read_exr(Path(folder) / IRRADIANCE, channels=(3, 4), key=key)[..., :3]
