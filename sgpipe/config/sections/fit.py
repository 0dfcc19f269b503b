"""`fit:` — materials and how to fit them (owned by the fit stage)."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Literal

from sgpipe.config.schema import InputPath, doc

_NAME = re.compile(r"^[A-Za-z0-9_][A-Za-z0-9_.-]*$")
#: views × importance samples a per-view mixture fit may hold at once (fit.view_gmm)
MAX_VIEW_SAMPLES = 1 << 25


@dataclass
class MaterialSpec:
    """One material: an analytic model with parameters, or a measured MERL file."""

    name: str = doc("Material name (referenced by scene objects); also the folder "
                    "<out>/fit/<name>/. Letters, digits, '_', '-', '.'.")
    model: str = doc("BRDF model: lambert, blinn_phong, cook_torrance, ward, "
                     "ashikhmin_shirley, beckmann, ggx, gltf_pbr (glTF 2.0 metal-rough: "
                     "base_color, metallic, roughness, anisotropy, emissive), merl (see "
                     "sgpipe.brdf).",
                     "lambert")
    params: dict[str, Any] = doc("Model parameters, e.g. {alpha: 0.1, kd: [0.2, 0.1, 0.05], "
                                 "ks: 0.9, fresnel: schlick, f0: 0.04}.", default_factory=dict)
    merl_file: InputPath | None = doc("MERL .binary file (model: merl).", None)

    def validate(self):
        if not _NAME.match(self.name):
            raise ValueError(f"name: must be letters, digits, '_', '-', '.' (got {self.name!r})")
        if self.model == "merl" and self.merl_file is None:
            raise ValueError("merl_file: model 'merl' needs merl_file")
        if self.model != "merl" and self.merl_file is not None:
            raise ValueError(f"merl_file: only used with model 'merl' (model is {self.model!r})")


@dataclass
class NdfSGSpec:
    """Wang09 §4 SG lobes of the NDF (microfacet form used by the SG renderer)."""

    enabled: bool = doc("Fit SG lobes to the NDF.", True)
    method: Literal["auto", "analytic", "lm", "lbfgsb"] = doc(
        "auto: analytic (eq 12 and equivalents) for isotropic parametric NDFs, "
        "Levenberg–Marquardt about +z for tabulated ones, L-BFGS-B with free axes for "
        "anisotropic ones.", "auto")
    lobes: int = doc("Lobes (0 = auto: Wang09's analytic lobe where it is within 1 % relative "
                     "L2 of D, 2 % of ∫D cos θ and 10 % RMS relative error where D is at least "
                     "10⁻⁴ of its peak (the glow of a bright light), else the fewest "
                     "Levenberg–Marquardt lobes that are (≤ 8; sharp GGX 5, Beckmann and Ward "
                     "1); 8 free-axis lobes for anisotropic NDFs).", 0,
                     ge=0, le=16)
    report_lobes: int = doc("Largest lobe count of the error-vs-lobes report (0 = none).", 4,
                            ge=0, le=16)
    anisotropic: Literal["asg", "sg"] = doc(
        "What `sg` renders anisotropic NDFs with: asg = anisotropic spherical Gaussians (Xu "
        "et al. 2013) fitted in h-space and warped per view into isotropic sub-lobes "
        "(ndf_asg.npz); sg = Wang09's SG lobes with free axes (ndf_sg.npz, always written: "
        "fis samples from them). Isotropic NDFs always use SG lobes.", "asg")
    asg_lobes: int = doc("ASG lobes sharing the tangent frame (0 = auto: the fewest of 1–3 "
                         "with relative L2 error ≤ 2 %: 1 for Beckmann / Ward, 3 for GGX's "
                         "tails).", 0, ge=0, le=8)


@dataclass
class ViewGmmSpec:
    """Töral19 §IV: per-view vMF mixtures of ρ(i, o_j)(n·i) fitted by spherical EM."""

    enabled: bool = doc("Fit the per-view mixtures.", True)
    lobes: int = doc("vMF lobes per view (paper: 8).", 8, ge=1, le=32)
    anisotropic_lobes: int = doc("vMF lobes per view for anisotropic BRDFs (0: `lobes`): an r:1 "
                                 "lobe needs a chain of about r/2 round vMFs.", 24, ge=0, le=32)
    samples: int = doc("Importance samples per view.", 4096, ge=64, le=1 << 20)
    iterations: int = doc("Maximum EM iterations per fit.", 100, ge=1, le=10000)
    tolerance: float = doc("EM stops when the log-likelihood changes less than this "
                           "(relative).", 1e-5, ge=0)
    theta_count: int = doc("View elevations θ_t = θ_max t/(count−1).", 16, ge=2, le=256)
    phi_count: int = doc("View azimuths (0 = auto: 1 for isotropic, 16 for anisotropic).", 0,
                         ge=0, le=256)
    theta_max_deg: float = doc("Largest view elevation (degrees).", 85.0, gt=0, le=89.9)
    component: Literal["specular", "full"] = doc(
        "Fit the specular part only (Töral19; the renderer adds the diffuse term) or the "
        "whole BRDF. Models without a specular lobe always use full.", "specular")
    coherent: bool = doc("Fit views in order, each from its neighbour's lobes with the Han07 "
                         "eq 23 alignment prior, so lobe k corresponds across views.", False)
    align: float = doc("Alignment strength C of Han07 eq 23 (coherent only).", 1.0, ge=0)
    roughness_entries: int = doc(
        "gltf_pbr (isotropic): also fit the specular mixtures at this many roughness values "
        "from 0.06 to the material's roughness factor (uniform in ln α), Schlick F0 as a "
        "linear basis, so that gmm renders textured roughness, metalness and base colour per "
        "pixel (view_gmm_rough.npz; 0: none, gmm renders the factors).", 16, ge=0, le=64)
    holdout: bool = doc("Measure interpolation error at held-out views halfway in θ (with "
                        "coherent: true also for independent fits, for comparison).", True)
    report_views_deg: list[float] = doc("View elevations for the error-vs-lobes curve and "
                                        "the slice previews.",
                                        default_factory=lambda: [0.0, 30.0, 60.0])
    report_lobes: int = doc("Largest lobe count of the error-vs-lobes curve (0 = none).", 8,
                            ge=0, le=32)

    def validate(self):
        views = self.theta_count * (self.phi_count or 16)    # 0: up to 16 azimuths
        if views * self.samples > MAX_VIEW_SAMPLES:
            raise ValueError(
                f"samples: theta_count × phi_count × samples must be at most 2^25 (every "
                f"view's samples are held at once, 56 bytes each: 1.9 GB), got {views} views "
                f"× {self.samples}")
        for k, v in enumerate(self.report_views_deg):
            if not 0.0 <= v < 90.0:
                raise ValueError(f"report_views_deg.{k}: must be in [0, 90), got {v}")


@dataclass
class FitSection:
    """Materials to fit and the two lobe representations produced for each."""

    materials: list[MaterialSpec] = doc("Materials.", default_factory=list)
    ndf_sg: NdfSGSpec = doc("Wang09 NDF lobes.", default_factory=NdfSGSpec)
    view_gmm: ViewGmmSpec = doc("Töral19 per-view mixtures.", default_factory=ViewGmmSpec)

    def validate(self):
        names = [m.name for m in self.materials]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"materials: duplicate material names {dup}")


__all__ = ["MaterialSpec", "NdfSGSpec", "ViewGmmSpec", "FitSection"]
