"""Envmap objects ↔ the `envmap/` artifacts (names, layouts, writers and readers:
`sgpipe.artifacts.envmap`): what the stage hands the writer, and the reference loaders that
rebuild Pyramid / MipChain / SGLight objects for tests and comparisons."""
from __future__ import annotations

from pathlib import Path

from sgpipe.artifacts import envmap as contract
from sgpipe.envmap.lightfit import SGLight
from sgpipe.envmap.mip import MipChain
from sgpipe.envmap.pyramid import Pyramid
from sgpipe.errors import BadInput


def pyramid_artifacts(pyr: Pyramid) -> contract.PyramidArtifacts:
    """A built pyramid as the contract stores it."""
    return contract.PyramidArtifacts(
        lambdas=pyr.lambdas, face_res=pyr.face_res, ratio=pyr.ratio, mean=pyr.mean,
        samples=pyr.samples, values=pyr.values, slopes=pyr.slopes, raw=pyr.raw,
        point_dirs=pyr.point_dirs, point_energy=pyr.point_energy)


def load_pyramid(folder: str | Path) -> Pyramid:
    """`<folder>/pyramid.npz` and its level EXRs → a Pyramid with `.lookup(p, λ)` (accurate)
    and `.lookup_simple(p, λ)` (bilinear samples, linear in ln λ)."""
    a = contract.read_pyramid(folder)
    if a.values is None:
        raise BadInput("file not found (the accurate lookup needs the B-spline coefficients)",
                       file=Path(folder) / contract.level_name(0, "coef"), key=contract.KEY)
    return Pyramid(lambdas=a.lambdas, face_res=a.face_res, values=a.values, slopes=a.slopes,
                   mean=a.mean, ratio=a.ratio, samples=a.samples, raw=a.raw,
                   point_dirs=a.point_dirs, point_energy=a.point_energy)


def load_mip_chain(folder: str | Path, kind: str = "cube") -> MipChain:
    """The box MIP chain (`kind` "cube" or "dp") → MipChain with lobe_lod / fis_lod."""
    a = contract.read_mip(folder, kind)
    return MipChain(a.kind, a.levels, b=a.b)


def load_light_fits(folder: str | Path) -> dict:
    """{"sg": SGLight, "sh": {"lmax", "coeffs", "irradiance_coeffs", ...}}."""
    sg = contract.read_light_sg(folder)
    return {"sg": SGLight(sg.axes, sg.sharpness, sg.amplitude),
            "sh": contract.read_light_sh(folder)}
