"""`normalmap:` — Han07 normal-map filtering precompute (owned by the normalmap stage)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from sgpipe.config.schema import doc

NormalmapMethod = Literal["vmf", "sh", "baselines"]


@dataclass
class NormalmapSection:
    """Filtered MIP pyramids of every `scene.objects[*].normal_map` (docs/HAN07.md)."""

    methods: list[NormalmapMethod] = doc(
        "What to precompute per normal map: 'vmf' (Han07 §7: J vMF lobes per texel per level "
        "as α and α·r textures), 'sh' (Han07 §5: NDF SH coefficients γ_lm per level), "
        "'baselines' (mean normal, normalised MIP, Toksvig factor, engine roughness bake).",
        default_factory=lambda: ["vmf", "sh", "baselines"])
    lobes: int = doc("vMF lobes J per texel (Han07 Fig 7: about four suffice).", 4, ge=1, le=8)
    sh_order: int = doc("Highest SH band l* of the NDF coefficients ((l*+1)² per texel; 2 "
                        "suffices for Lambert, l* ~ √(4s) for Blinn–Phong exponent s; "
                        "nm_sh_han07 needs that).", 4, ge=0, le=16)
    levels: int | None = doc("MIP levels to build from the full-resolution map down "
                             "(null = every level down to 1×1).", None, ge=1)
    bilinear_samples: Literal[1, 2, 4] = doc(
        "Sub-samples s per finest-texel axis of the bilinearly interpolated map (as the "
        "reference and the renderer read it) from which every level ≥ 1 is built: s × s per "
        "texel at the sub-texel centres; 1 = the texel-centre normals only (Han07 eq 9 on the "
        "texels). Cost: the vMF fit grows about s²×.", 2)
    colour_features: bool = doc(
        "Filter the colour textures of the objects sharing a map (their materials' "
        "render.material_textures kd_map / ks_map) together with its NDF (Han07 eq 22): each "
        "vMF lobe carries the mean colour of its own normals, so a coarse texel keeps which "
        "colour belongs to which facet. A glTF material's base-colour and metallic-roughness "
        "textures likewise: each lobe its own kd, F0 and roughness. false: vmf reads the "
        "colour's plain MIP, as the other methods do.", True)
    align: bool = doc("Align lobes across neighbouring texels and levels (Han07 §7.3, eq 23) "
                      "so that trilinear interpolation of the textures stays accurate.", True)
    align_strength: float = doc("C′ of Han07's appendix: the eq 23 pull of a lobe's axis "
                                "towards its neighbours' (C = C′/κ_j); 0 keeps only the slot "
                                "matching.", 1.0, ge=0.0, le=100.0)
    em_iterations: int = doc("Maximum spherical-EM iterations per texel (Han07: seldom more "
                             "than 10).", 20, ge=1, le=500)
    align_iterations: int = doc("EM iterations per texel of the aligned (coarse-to-fine) "
                                "pass, which starts from the converged unaligned fit.", 5,
                                ge=1, le=100)
    em_tolerance: float = doc("EM stops when the mean log-likelihood changes by less than "
                              "this (relative).", 1e-5, gt=0.0, lt=1.0)
    kappa_max: float = doc("Cap on κ (a single normal is a delta: κ = kappa_max). The stored "
                           "length |r| is then 1 − ~1/κ, which float32 textures hold.", 1e4,
                           ge=10.0, le=1e6)
    toksvig_exponent: float = doc("Blinn–Phong exponent s of the stored Toksvig factor "
                                  "f = |n̄|/(|n̄| + s(1 − |n̄|)).", 32.0, gt=0.0)
    engine_alpha: float = doc("Base Beckmann/GGX roughness α of the stored engine bake "
                              "α′ = √(α² + 2/κ).", 0.1, gt=0.0, le=1.0)
    preview_light_deg: tuple[float, float] = doc(
        "Previews: elevation and azimuth (degrees, tangent frame) of the light that shades "
        "the level previews.", (45.0, 30.0))

    def validate(self):
        if not self.methods:
            raise ValueError("methods: list at least one of vmf, sh, baselines")
        dup = sorted({m for m in self.methods if self.methods.count(m) > 1})
        if dup:
            raise ValueError(f"methods: duplicate entries {dup}")
