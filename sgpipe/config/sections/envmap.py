"""`envmap:` — environment prefiltering (owned by the environment stage)."""

from __future__ import annotations

from dataclasses import dataclass

from sgpipe.config.schema import InputPath, doc


@dataclass
class EnvmapSection:
    """Environment map and what to precompute from it (docs/ARTIFACTS.md, `envmap/`)."""

    environment: InputPath = doc("Lat-long HDR environment map (EXR/HDR, 3 or 4 channels, "
                                 "CONVENTIONS mapping).")
    cube_resolution: int = doc("Face resolution N of the finest cubemap (a power of two).",
                               128, ge=4, le=4096)
    pyramid_ratio: float = doc("Γ_L pyramid: λ ratio between consecutive levels (√2 keeps the "
                               "λ interpolation within ~1 %).", 1.4142135623730951, gt=1.0, le=4.0)
    pyramid_texels_per_sigma: float = doc("Γ_L pyramid: output texels per kernel σ = 1/√λ at a "
                                          "face centre (each level's resolution; λ_0 = (N/4)², "
                                          "σ = 2 finest texels). 0 = from the content: 2 when a "
                                          "bright layer above 10³ × the median stays in the "
                                          "levels (a sun too large for the point set: its tails "
                                          "next to dark sky need the denser B-spline), else 1.5 "
                                          "(bounded contrast: as accurate with fewer texels). "
                                          "Below ~1.3 the levels are too coarse to chain and all "
                                          "come from the map (slower).", 0.0, ge=0.0, le=8.0)
    pyramid_lambda_min: float = doc("Γ_L pyramid: levels continue down to the first λ <= this.",
                                    0.25, gt=0.0, le=4.0)
    pyramid_source_texels_per_sigma: float = doc(
        "Γ_L pyramid: for the broad levels gathered from the map's moment MIP (λ < 20; sharper "
        "levels are chained from sharper ones): its texels per σ (accuracy vs speed).", 1.5,
        ge=0.5, le=8.0)
    pyramid_bright_factor: float = doc(
        "Texels brighter than this × the median go to the exact 'bright' layer.", 16.0, gt=1.0)
    pyramid_max_points: int = doc(
        "Γ_L pyramid: a bright layer of at most this many texels (a sun, a few lamps) is kept "
        "as exact point masses beside the levels (no λ-interpolation error); 0 = always in the "
        "levels.", 256, ge=0, le=4096)
    pyramid_bright_clusters: bool = doc(
        "Γ_L pyramid: a bright layer of more texels than `pyramid_max_points` (large lamps) is "
        "kept as that many point masses, each the energy of a 2^k × 2^k block of texels at its "
        "energy-weighted direction (k as small as the count allows), instead of going into the "
        "levels, so that sg and gmm shade them with the exact BRDF (GGX's tails far from a "
        "lamp's highlight). Blocks are 2^k texels wide: lobes much wider than a block (α ≳ "
        "0.05) gain, sharper lobes see the blocks as separate points (a near-mirror shows a "
        "lamp as dots), hence off by default; false: the lamps go into the levels.", False)
    mip_coverage: float = doc("Töral19 eq 7–8: fraction a of the lobe whose solid angle sets "
                              "the MIP level.", 0.9, gt=0.0, lt=1.0)
    dp_scale: float = doc("Dual-paraboloid scale b (Töral19 eq 11; 1.2 as in GPU Gems 3).",
                          1.2, ge=1.0, le=2.0)
    dp_resolution: int | None = doc("Dual-paraboloid resolution per hemisphere (default: "
                                    "cube_resolution).", None, ge=4, le=4096)
    sg_lobes: int = doc("SG light fit: number of lobes (Wang09 §6: < 10).", 8, ge=1, le=9)
    sh_lmax: int = doc("SH light projection: highest band l (4 = Green06's fifth order).", 4,
                       ge=0, le=10)
    irradiance_height: int = doc("Height of the exact irradiance lat-long map (width = 2×).",
                                 32, ge=4, le=512)

    def validate(self):
        k = self.pyramid_texels_per_sigma
        if 0.0 < k < 1.0:
            raise ValueError(f"pyramid_texels_per_sigma: 0 (automatic) or >= 1, got {k}")
        n = self.cube_resolution
        if n & (n - 1):
            raise ValueError(f"cube_resolution: must be a power of two, got {n}")
        d = self.dp_resolution
        if d is not None and d & (d - 1):
            raise ValueError(f"dp_resolution: must be a power of two, got {d}")
