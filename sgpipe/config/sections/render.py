"""`render:` — camera, lights, methods (owned by the render stage)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from sgpipe.config.schema import InputPath, doc
from sgpipe.render.methods import (GREEN06_SWITCHES, HAN07_SH_SWITCHES, HAN07_SWITCHES,
                                   METHOD_NAMES, METHODS, REFERENCE, TORAL19_SWITCHES,
                                   WANG09_SWITCHES)

#: A `render.methods` entry: an OpenCL method of the registry or the Monte Carlo `reference`.
RenderMethod = Literal[METHOD_NAMES]
Wang09Improvement = Literal[tuple(WANG09_SWITCHES)]
Toral19Improvement = Literal[tuple(TORAL19_SWITCHES)]
Green06Improvement = Literal[tuple(GREEN06_SWITCHES)]
Han07Improvement = Literal[tuple(HAN07_SWITCHES)]
Han07ShImprovement = Literal[tuple(HAN07_SH_SWITCHES)]


@dataclass
class CameraSpec:
    """Pinhole camera (CONVENTIONS: eye/target/up/fov_deg/width/height; pixel (0,0) top-left)."""

    eye: tuple[float, float, float] = doc("Camera position.", (0.0, 1.0, 4.0))
    target: tuple[float, float, float] = doc("Point looked at.", (0.0, 0.5, 0.0))
    up: tuple[float, float, float] = doc("Up vector.", (0.0, 1.0, 0.0))
    fov_deg: float = doc("Vertical field of view (degrees).", 40.0, gt=0, lt=180)
    width: int = doc("Image width (pixels; at most 8192: every pass holds the frame's G-buffer "
                     "in memory).", 256, ge=1, le=8192)
    height: int = doc("Image height (pixels; at most 8192, as width).", 256, ge=1, le=8192)


@dataclass
class LightSpec:
    """A local light (Wang09 eq 32–33), rendered as one SG lobe whose integral is the light's
    irradiance; the Monte Carlo reference treats it as the delta light of the same strength, or
    as a sphere / disc of its radius with `render.reference_area_lights`."""

    type: Literal["point", "directional"] = doc("Light type.", "point")
    position: tuple[float, float, float] = doc("Position (point lights).", (2.0, 4.0, 2.0))
    direction: tuple[float, float, float] = doc(
        "Direction from the scene TOWARDS the light (directional lights).", (0.0, 1.0, 0.0))
    intensity: tuple[float, float, float] = doc(
        "RGB strength: radiant intensity I in W/sr (point: irradiance I/d² at distance d) or "
        "irradiance E in W/m² on a surface facing the light (directional).", (10.0, 10.0, 10.0))
    radius: float = doc("Size: sphere radius in world units (point) or tan of the angular "
                        "radius (directional); sets the SG sharpness f_a⁻¹(2πr²/d²) and the "
                        "shadow softness of the SG methods.", 0.05, ge=0)

    def validate(self):
        if any(c < 0 for c in self.intensity):
            raise ValueError("intensity: must be >= 0")
        if self.type == "directional" and sum(c * c for c in self.direction) < 1e-20:
            raise ValueError("direction: must be a non-zero vector")


@dataclass
class MaterialTextureSpec:
    """Spatially varying parameters (SVBRDF): textures multiplying a material's kd / ks."""

    material: str = doc("Name of a material in `fit.materials`.")
    kd_map: InputPath | None = doc("RGB texture multiplying kd (linear, OBJ uv: v = 0 is the "
                                   "bottom row, repeat addressing).", None)
    ks_map: InputPath | None = doc("RGB texture multiplying ks (same addressing).", None)


@dataclass
class PixelFilterSpec:
    """Reconstruction filter of the `reference` over the image plane (sgpipe.reference.
    pixel_filter): separable, its samples drawn from the filter (stratified R2 pattern)."""

    type: Literal["box", "tent", "gaussian", "center"] = doc(
        "box: uniform over the pixel (radius ½); tent: 1 − |x|/r per axis; gaussian: "
        "e^{−x²/2σ²} − e^{−r²/2σ²} per axis (Mitsuba 3's); center: one ray through the pixel "
        "centre, no integration over the pixel (the real-time methods' single ray).", "box")
    radius: float | None = doc("Half-width of the support in pixels; null: the type's default "
                               "(box 0.5, tent 1, gaussian 4·stddev).", None, gt=0, le=16)
    stddev: float = doc("Standard deviation σ of the gaussian filter (pixels).", 0.5, gt=0,
                        le=8)


@dataclass
class EnvironmentRotationSpec:
    """A rotation of the whole environment at render time, for every method and the reference
    (no precompute reruns): what the map shows in direction d appears in world direction R·d."""

    axis: tuple[float, float, float] = doc("Rotation axis in world coordinates (any non-zero "
                                           "length; +Y is up).", (0.0, 1.0, 0.0))
    angle_deg: float = doc("Angle about the axis in degrees, right-handed (counter-clockwise "
                           "seen from the axis tip); 0: no rotation.", 0.0, ge=-360, le=360)

    def validate(self):
        if not sum(c * c for c in self.axis) > 1e-20:
            raise ValueError(f"axis: must be a non-zero vector, got {list(self.axis)}")

    def matrix(self):
        """World ← map rotation (3, 3), or None for a zero angle."""
        if self.angle_deg == 0.0:
            return None
        from sgpipe.core.rotation import rotation_matrix
        return rotation_matrix(self.axis, self.angle_deg)


@dataclass
class RenderSection:
    """What to render and how to compare it."""

    camera: CameraSpec = doc("Camera.", default_factory=CameraSpec)
    methods: list[RenderMethod] = doc(
        "Rendering methods to run (" + "; ".join(f"{m.name}: {m.summary}" for m in METHODS.values())
        + f"; {REFERENCE}: Monte Carlo ground truth).", default_factory=lambda: ["sg"])
    lights: list[LightSpec] = doc("Point / directional lights added to the environment.",
                                  default_factory=list)
    environment_exposure: float = doc("Environment radiance scale in stops (× 2^value) for "
                                      "every method.", 0.0, ge=-30, le=30)
    environment_rotation: EnvironmentRotationSpec = doc(
        "Rotate the environment by `angle_deg` about `axis` at render time, for every method "
        "(each OpenCL method and the reference) and the background, without rerunning the "
        "envmap stage: what the map shows in direction d appears in direction R·d. E.g. "
        "{axis: [0, 1, 0], angle_deg: 90} turns the map's −Z (u = 0) to −X.",
        default_factory=EnvironmentRotationSpec)
    preview_exposure: float = doc("Exposure (stops) of the PNG previews (clamp + sRGB).", 0.0,
                                  ge=-30, le=30)
    background: bool = doc("Show the environment where primary rays miss (else black).", True)
    spp: int = doc("Samples per pixel of the `reference` method (at most 2²⁰: its time grows "
                   "linearly with them).", 256, ge=1, le=2 ** 20)
    pixel_filter: PixelFilterSpec = doc(
        "Pixel filter of the `reference`: each sample's camera ray passes through a sub-pixel "
        "position drawn from it, so silhouettes and directly seen lamps are integrated over "
        "the pixel.", default_factory=PixelFilterSpec)
    reference_area_lights: bool = doc(
        "reference: lights of radius > 0 as what the SG methods approximate — a sphere of "
        "radiance I/(πr²) (point) or a disc of angular radius atan(radius) and radiance "
        "E/(π sin²α) (directional), sampled in their cone (soft shadows, broadened "
        "highlights); false: delta lights of the same intensity / irradiance.", False)
    reference_bounces: int = doc(
        "reference: indirect bounces per path (interreflection). 0: direct lighting only; N: "
        "paths continue by BRDF importance sampling through up to N further surfaces, each "
        "adding its direct light (env / BRDF samples with MIS, lights); no Russian roulette. "
        "Mitsuba's `path` integrator with max_depth = N + 2.", 0, ge=0, le=16)
    reference_mapped_backfacing: Literal["lift", "black"] = doc(
        "reference: where the view lies behind a normal map's normal (grazing views of tilted "
        "texels). lift: shaded at a grazing view (elevation asin 0.01) in the mapped frame, as "
        "every OpenCL method does; black: nothing is reflected there (Mitsuba 3's `normalmap` "
        "BSDF; docs/CONVENTIONS.md).", "lift")
    supersample: int = doc("Real-time methods (sg, gmm, fis): N → N×N G-buffers at the "
                           "centres of an N×N grid of sub-pixel cells, shaded and averaged "
                           "(a box filter, comparable with the reference's default); 1 = one "
                           "ray through each pixel centre.", 1, ge=1, le=16)
    fis_samples: int = doc("Samples per pixel N of `fis` (Töral19 uses about 40).", 40, ge=1,
                           le=4096)
    gmm_taps: int = doc("gmm: trilinear MIP taps per lobe spread over the lobe's vMF (1 = "
                        "Töral19's single lobe-sized lookup, eq 6–10; 16 is 5–14 dB closer to the "
                        "reference on the figures' spheres at about fis's cost).", 16, ge=1,
                        le=64)
    gmm_interpolate: bool = doc("gmm: interpolate lobes between fitted views when the fit is "
                                "coherent (else nearest view).", True)
    gmm_carry: Literal["warp", "rotate", "none"] = doc(
        "gmm: how a fitted view's lobes reach the pixel's view. warp: through each lobe's half "
        "vector (the NDF stays put; anisotropic lobes keep their orientation); rotate: rigidly "
        "with the mirror direction; none: Töral19's nearest view as fitted.", "warp")
    gmm_points: bool = doc("gmm: the environment's bright point set (sun, lamps; the envmap "
                           "stage's pyramid.npz points) is summed exactly per lobe (Σ E_p vMF(p)) "
                           "and the MIP chain holds the map without it; false: Töral19's MIP "
                           "lookups of the whole map (a sun smaller than the lobe's texel moves "
                           "to the texel centre).", True)
    baseline_shadows: bool = doc("gmm/fis: apply the SSDF visibility as sg does (the papers' "
                                 "baselines are unshadowed; false reproduces that).", True)
    fh: Literal["table", "sigmoid"] = doc(
        "SG × SSDF visibility integral f_h (Wang09 eq 30): `table` = the exact integral "
        "tabulated (default), `sigmoid` = the appendix's form (eq 47–49) with sgpipe's refitted "
        "coefficients (`sg_wang09` uses the printed ones).", "table")
    sg_wang09_adds: list[Wang09Improvement] = doc(
        "sg_wang09: sgpipe improvements to give back to Wang09 as published (all of them: "
        "`sg`; one at a time: the ablation ladder, docs/WANG09.md): warp3 (3 sub-lobes, "
        "anisotropic warp), spec_cosine (expected clamped cosine instead of C* ⊗), asg (ASG "
        "NDF lobes), fh (render.fh instead of the printed sigmoid), sharp_lights (limit of the "
        "products for lights sharper than λ 64), exact_brdf (NDF table at suns and sharp "
        "lights).", default_factory=list)
    gmm_toral19_adds: list[Toral19Improvement] = doc(
        "gmm_toral19: sgpipe improvements to give back to Töral19 as published (all of them: "
        "`gmm`; one at a time: the ablation ladder, docs/TORAL19.md): cube_chain (the cube's "
        "box MIP chain instead of the dual paraboloid), taps (render.gmm_taps taps over each "
        "lobe instead of one lookup), points (render.gmm_points; needs cube_chain), carry "
        "(render.gmm_carry instead of the nearest view's lobes), fit (fit.view_gmm's mixtures "
        "instead of 8 independent lobes per view).", default_factory=list)
    transport_green06_adds: list[Green06Improvement] = doc(
        "transport_green06: sgpipe improvements to give back to Green06 §5 as published (all "
        "of them: `transport`; docs/GREEN06.md): ratio (the environment's glossy part as the "
        "BRDF's own lobes times the shadowed / unshadowed Gaussians' ratio, with "
        "transport.sampling: lobe), exact_lights (the exact specular BRDF at suns and sharp "
        "lights, with the SSDF horizon).", default_factory=list)
    vmf_han07_adds: list[Han07Improvement] = doc(
        "vmf_han07: sgpipe improvements to give back to Han07 §7–8 as published (all of them: "
        "`vmf`; docs/HAN07.md): env_specular (warped lobes through the Γ_L pyramid and the "
        "point set exactly, instead of eq 26's SH at l* = 8), env_diffuse (the SG light sum "
        "instead of eq 25's SH), level0 (bilinear-normal taps at level 0 instead of eq 24's "
        "blend of delta lobes), box (render.normalmap_footprint instead of the trilinear "
        "lookup).", default_factory=list)
    nm_sh_han07_adds: list[Han07ShImprovement] = doc(
        "nm_sh_han07: sgpipe improvements to give back to Han07 §5 as published (all of them: "
        "`nm_sh`; docs/HAN07.md): box (render.normalmap_footprint instead of the trilinear "
        "lookup), level0 (the bare material at level 0's bilinear normals instead of their "
        "γ_lm), bands (every stored SH band instead of l* = ⌈√(4s)⌉).", default_factory=list)
    compare_to: str | None = doc("Method whose image is the ground truth for `sgpipe compare`"
                                 " of every other method (usually `reference`); null: none.",
                                 None)
    material_textures: list[MaterialTextureSpec] = doc("SVBRDF textures per material.",
                                                       default_factory=list)
    timing_repeats: int = doc("Warm shading launches per method for the timing (minimum is "
                              "reported).", 3, ge=1, le=100)
    normalmap_max_taps: int = doc(
        "Normal-map methods (vmf, nm_sh, normals_mip, toksvig, engine_bake): texture taps "
        "along the pixel footprint's longer axis. 1: "
        "isotropic, the MIP level of the longer UV derivative; N > 1: anisotropic, the level of "
        "the shorter one raised until N taps span the longer, their α, α·r and mean normals "
        "averaged before κ and μ are recovered (Han07 eq 24, Fig 3).", 1, ge=1, le=64)
    normalmap_footprint: Literal["trilinear", "box"] = doc(
        "Normal-map methods: the filter over the pixel's texture footprint. trilinear: MIP "
        "level log2 of the footprint, bilinear within it and linear between levels (a tent "
        "about twice the pixel; normalmap_max_taps taps along an anisotropic one), the lobes' "
        "α, α·r blended (eq 24). box: the reference's box pixel filter — at the finest level "
        "where the footprint's box (its u and v extents) overlaps ≤ 9 texels, each texel "
        "weighted by its overlap and its lobes kept as they are (at level 0: a grid of up to "
        "4 × 4 bilinear-normal taps, each its own lobe); an elongated footprint whose box needs "
        "a coarser level than the taps keeps the taps. About 4× trilinear's cost for vmf "
        "(docs/HAN07.md).", "box")

    def validate(self):
        if self.compare_to is not None and self.compare_to not in self.methods:
            raise ValueError(f"compare_to: {self.compare_to!r} is not one of methods "
                             f"{self.methods}")
        if len(set(self.methods)) != len(self.methods):
            raise ValueError("methods: listed twice")
        if "points" in self.gmm_toral19_adds and "cube_chain" not in self.gmm_toral19_adds:
            raise ValueError("gmm_toral19_adds: points needs cube_chain (the point set is "
                             "taken out of the cube chain only)")
