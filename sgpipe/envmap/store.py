"""The `envmap/` artifact contract (docs/ARTIFACTS.md): file layout of the pyramid, MIP chains
and light fits, and the reference readers the renderer and tests use."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from sgpipe.envmap.lightfit import SGLight
from sgpipe.envmap.mip import MipChain
from sgpipe.envmap.pyramid import BORDER, Pyramid
from sgpipe.errors import BadInput
from sgpipe.io import read_exr, read_npz

PYRAMID_INDEX = "pyramid.npz"
MIP_INDEX = "mip.npz"
LIGHT_SG = "light_sg.npz"
LIGHT_SH = "light_sh.npz"
RAW_LEVEL = "pyramid/raw.exr"        # the finest cubemap of the levels' content (λ → ∞ end)


def level_name(level: int, kind: str = "level") -> str:
    return f"pyramid/{kind}_{level:02d}.exr"


def pyramid_files(pyr: Pyramid):
    """[(name, image, metadata, png)] for the pyramid EXRs: `level_LL` plain V samples (border
    1, bilinear), `coef_LL` / `slope_LL` cubic B-spline coefficients of V and m (border 2)."""
    out = []
    for l, (lam, n) in enumerate(zip(pyr.lambdas, pyr.face_res)):
        meta = {"lambda": float(lam), "level": l, "face_res": int(n), "normalized": 1}
        out.append((level_name(l), pyr.samples[l],
                    {**meta, "quantity": "V", "border": 1, "layout": "cube6v_b1",
                     "basis": "samples"}, True))
        b2 = {**meta, "border": BORDER, "layout": "cube6v_b2", "basis": "cubic_bspline"}
        out.append((level_name(l, "coef"), pyr.values[l], {**b2, "quantity": "V"}, False))
        out.append((level_name(l, "slope"), pyr.slopes[l],
                    {**b2, "quantity": "dlnG_dlnlambda"}, False))
    if pyr.raw is not None:
        out.append((RAW_LEVEL, pyr.raw, {"face_res": int(pyr.raw.shape[1] - 2), "border": 1,
                                         "layout": "cube6v_b1", "quantity": "L",
                                         "basis": "samples"}, False))
    return out


def pyramid_index(pyr: Pyramid) -> dict:
    def offs(imgs):
        return np.concatenate([[0], np.cumsum([v.shape[0] * v.shape[1] for v in imgs])]
                              ).astype(np.int64)
    return {"lambdas": np.asarray(pyr.lambdas, np.float64),
            "face_res": np.asarray(pyr.face_res, np.int32),
            "offsets": offs(pyr.samples), "border": np.int32(1),
            "coef_offsets": offs(pyr.values), "coef_border": np.int32(BORDER),
            "mean": np.asarray(pyr.mean, np.float64), "ratio": np.float64(pyr.ratio),
            "point_dirs": np.asarray(pyr.point_dirs, np.float64).reshape(-1, 3),
            "point_energy": np.asarray(pyr.point_energy, np.float64).reshape(-1, 3)}


def load_pyramid(folder: str | Path) -> Pyramid:
    """Read `<folder>/pyramid.npz` and its level EXRs → a Pyramid with `.lookup(p, λ)`
    (accurate) and `.lookup_simple(p, λ)` (bilinear samples, linear in ln λ)."""
    folder = Path(folder)
    idx = read_npz(folder / PYRAMID_INDEX, required=("lambdas", "face_res", "mean", "ratio"))
    values, slopes, samples = [], [], []
    for l, n in enumerate(idx["face_res"]):
        for kind, dst, b in (("coef", values, BORDER), ("slope", slopes, BORDER),
                             ("level", samples, 1)):
            img = read_exr(folder / level_name(l, kind), channels=(3,))
            if img.shape != (6 * (n + 2 * b), n + 2 * b, 3):
                raise BadInput(f"level {l} has shape {img.shape}, index says face_res {n}",
                               file=folder / level_name(l, kind))
            dst.append(img)
    points = {k: np.asarray(idx[k], np.float64).reshape(-1, 3) if k in idx else np.zeros((0, 3))
              for k in ("point_dirs", "point_energy")}
    raw = read_exr(folder / RAW_LEVEL, channels=(3,)) if (folder / RAW_LEVEL).is_file() else None
    return Pyramid(lambdas=idx["lambdas"], face_res=idx["face_res"].astype(np.int64),
                   values=values, slopes=slopes, mean=idx["mean"], ratio=float(idx["ratio"]),
                   samples=samples, raw=raw, **points)


def mip_files(cube: MipChain, dp: MipChain):
    out = []
    for m, (img, n) in enumerate(zip(cube.levels, cube.res)):
        out.append((f"mip/cube_{m:02d}.exr", img, {"level": m, "face_res": n, "border": 1,
                                                    "layout": "cube6v_b1"}, True))
    for m, (img, n) in enumerate(zip(dp.levels, dp.res)):
        out.append((f"mip/dp_{m:02d}.exr", img, {"level": m, "res": n, "b": dp.b,
                                                  "layout": "dp2h"}, True))
    return out


def mip_index(cube: MipChain, dp: MipChain) -> dict:
    sizes = [v.shape[0] * v.shape[1] for v in cube.levels]
    dsz = [v.shape[0] * v.shape[1] for v in dp.levels]
    return {"cube_res": np.asarray(cube.res, np.int32),
            "cube_offsets": np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
            "dp_res": np.asarray(dp.res, np.int32),
            "dp_offsets": np.concatenate([[0], np.cumsum(dsz)]).astype(np.int64),
            "dp_b": np.float64(dp.b), "N": np.int32(cube.res[0])}


def load_mip_chain(folder: str | Path, kind: str = "cube") -> MipChain:
    """Read the box MIP chain (`kind` "cube" or "dp") → MipChain with lobe_lod / fis_lod."""
    folder = Path(folder)
    idx = read_npz(folder / MIP_INDEX, required=("cube_res", "dp_res", "dp_b"))
    if kind == "cube":
        levels = [read_exr(folder / f"mip/cube_{m:02d}.exr", channels=(3,))
                  for m in range(len(idx["cube_res"]))]
        return MipChain("cube", levels)
    if kind == "dp":
        levels = [read_exr(folder / f"mip/dp_{m:02d}.exr", channels=(3,))
                  for m in range(len(idx["dp_res"]))]
        return MipChain("dp", levels, b=float(idx["dp_b"]))
    raise ValueError(f"kind must be 'cube' or 'dp', got {kind!r}")


def load_light_fits(folder: str | Path) -> dict:
    """{"sg": SGLight, "sh": {"lmax", "coeffs", "irradiance_coeffs"}} from the light-fit NPZs."""
    folder = Path(folder)
    sg = read_npz(folder / LIGHT_SG, required=("axes", "sharpness", "amplitude"))
    sh = read_npz(folder / LIGHT_SH, required=("lmax", "coeffs", "irradiance_coeffs"))
    return {"sg": SGLight(sg["axes"], sg["sharpness"], sg["amplitude"]), "sh": sh}
