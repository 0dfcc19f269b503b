"""The OpenCL shading methods, registered once: kernel, compile-time defines, kernel parameters
and what the method needs and honours. Derived from it: the config's `render.methods` choices,
the render stage's dispatch and flags, the renderer's builds and launches (values bound to the
parameters by name), and the kernels' parameter lists (`<KERNEL>_ARGS` in the generated
`methods.h`).

Adding a method = one kernel file `kernels/<kernel>.cl` defining
`__kernel void <kernel>(<KERNEL>_ARGS)` + one `Method` in `METHODS`. Plain data: the config
imports it without loading OpenCL.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

#: Kernel parameters every method takes first: the G-buffer, objects and their SSDF data,
#: materials, textures, per pixel the UV derivatives (scene.footprint) and the scratch records
#: of textured materials (declared as the kernels read them; comma-separated).
PIXEL_PARAMS = """
    const int n,
    __global const float4 *gnrm, __global const float4 *gtan, __global const float4 *gview,
    __global const float4 *gpos, __global const float2 *guv,
    __global const int *gobj, __global const int *gtri, __global const float2 *gbary,
    __global const int8 *objs, __global const float4 *objf,
    __global const int *vfaces, __global const float *coeffs,
    __global const float *ssdf_data,
    __global const float *mats, __global const float4 *lobes, __global const float *tables,
    __global const float4 *texels, __global const int4 *texinfo, __global const float4 *texaff,
    __global const float4 *gduv, __global float *pxmat"""

#: ... what the MIP-chain methods (gmm, fis) take next: per-view mixtures / tabulated NDFs,
#: the box MIP chain, the diffuse SG light fit, the lobe coverage a, the local lights.
MIP_PARAMS = """
    __global const float4 *gmm, __global const int4 *ndf_info,
    __global const float4 *mip, __global const int *mip_off, __global const int *mip_res,
    const int mip_n,
    __global const float4 *env_sg, const int n_env_sg, const float env_scale,
    const float coverage,
    __global const float4 *lights, const int n_lights"""

#: ... what `gmm` takes next: the MIP chain its lobes read (levels, offsets, resolutions,
#: count, dual-paraboloid scale b): the box cube chain of the map minus the point set when
#: render.gmm_points, else `mip` itself; for `gmm_toral19` as published the dual-paraboloid
#: chain (Töral19 eq 11); then the point set summed exactly.
GMM_CHAIN_PARAMS = """
    __global const float4 *gmm_mip, __global const int *gmm_mip_off,
    __global const int *gmm_mip_res, const int gmm_mip_n, const float gmm_dp_b,
    __global const float4 *pyr_pts, const int n_gmm_pts"""

#: ... and what every method takes last.
TAIL_PARAMS = """
    const int flags,
    __global float4 *out"""


@dataclass(frozen=True)
class Method:
    """One OpenCL shading method of `render.methods`."""

    name: str
    summary: str                   # its part of the config's `methods` doc
    kernel: str                    # kernels/<kernel>.cl and its __kernel function
    params: tuple[str, ...]        # the kernel's parameters: groups of C declarations, in order
    defines: tuple[str, ...] = ()  # per-scene defines it compiles with (Renderer.defines)
    baseline_shadows: bool = False  # SSDF shadows follow `render.baseline_shadows` (else on)
    needs_view_gmm: bool = False   # reads the fit's per-view mixtures (view_gmm.npz)
    needs_ndf_table: bool = False  # reads the exact NDF tabulated from the BRDF
    needs_transport: bool = False  # reads the transport stage's Gaussians (render.transport_data)
    needs_normalmap: bool = False  # reads the Han07 normal-map pyramids (render.normalmap_data)
    #: defines it always compiles with, after every other (a published variant's switches; a
    #: value None removes the define)
    fixed_defines: tuple[tuple[str, object], ...] = ()

    @cached_property
    def parameters(self) -> list[tuple[str, str]]:
        """[(C type, name)] of the kernel parameters, in order."""
        out = []
        for decl in ",".join(self.params).split(","):
            decl = " ".join(decl.split())
            cut = max(decl.rfind(" "), decl.rfind("*")) + 1
            out.append((decl[:cut].strip(), decl[cut:]))
        return out


#: ... what `sg` takes next: the accurate Γ_L chain ((V, m) B-spline coefficient pairs, border 2,
#: cubemap.h) with its point set and unfiltered map, the diffuse SG light fit, the local lights,
#: the NDF tables' records (the point set's exact BRDF).
SG_PARAMS = """
    __global const float4 *pyr, __global const int *pyr_off, __global const int *pyr_res,
    __global const float *pyr_lam, const int pyr_n, const float pyr_log_ratio,
    const float4 env_mean,
    __global const float4 *pyr_pts, const int n_pts,
    __global const float4 *pyr_raw, const int raw_n,
    __global const float4 *env_sg, const int n_env_sg, const float env_scale,
    __global const float4 *lights, const int n_lights,
    __global const int4 *ndf_info"""

#: ... what `transport` (Green06) takes next: per object (first vertex, first face, K, has data),
#: the transport meshes' faces, the Gaussians (shadowed, and unshadowed), SH transfer vectors
#: (whole, and the interreflected part alone), diffuse f_d, the light's SH coefficients (whole
#: map, map minus the point set, the point set), the point set merged into small lights
#: (direction, sharpness; energy), the 92-view lookup tables (render.transport_data), the
#: accurate Γ_L chain, the local lights, the NDF tables' records (delta lights' exact BRDF).
TRANSPORT_PARAMS = """
    __global const int4 *tp_obj, __global const int *tp_faces, __global const float4 *tp_gauss,
    __global const float4 *tp_gauss_open,
    __global const float *tp_sh, __global const float *tp_sh_ind, __global const float4 *tp_fd,
    __global const float4 *tp_light_sh, const int tp_sh_n,
    __global const float4 *tp_suns, const int tp_n_suns,
    __global const float4 *tp_vinv, __global const int4 *tp_vtri,
    __global const float4 *pyr, __global const int *pyr_off, __global const int *pyr_res,
    __global const float *pyr_lam, const int pyr_n, const float pyr_log_ratio,
    const float4 env_mean,
    __global const float4 *pyr_pts, const int n_pts,
    __global const float4 *pyr_raw, const int raw_n, const float env_scale,
    __global const float4 *lights, const int n_lights,
    __global const int4 *ndf_info"""

#: ... what the normal-map methods (`vmf`, `normals_mip`, `toksvig`, `engine_bake`, `nm_sh`;
#: Han07) take next: the packed pyramids and per-object BRDF records (render.normalmap_data),
#: the environment's SH coefficients, the
#: diffuse SG light fit, the local lights, then the accurate Γ_L chain (environment specular).
NM_PARAMS = """
    __global const float4 *nm_data, __global const int4 *nm_levels, __global const int4 *nm_info,
    __global const float *nm_brdf,
    __global const float4 *nm_env_sh, const int n_env_sh, __global const float4 *nm_env_sh8,
    __global const float4 *env_sg, const int n_env_sg, const float env_scale,
    __global const float4 *lights, const int n_lights,
    __global const float4 *pyr, __global const int *pyr_off, __global const int *pyr_res,
    __global const float *pyr_lam, const int pyr_n, const float pyr_log_ratio,
    const float4 env_mean,
    __global const float4 *pyr_pts, const int n_pts,
    __global const float4 *pyr_raw, const int raw_n"""

#: What makes `sg_wang09` Wang09 §7 as published, one entry per sgpipe improvement that `sg`
#: has over the paper (its compile-time defines; None removes one). `render.sg_wang09_adds`
#: names improvements to give `sg_wang09` back — all of them make it `sg` (a test checks), one
#: at a time they make the ablation ladder of docs/results/wang09.md.
WANG09_SWITCHES: dict[str, tuple[tuple[str, object], ...]] = {
    # eq 17–21: one isotropic warped lobe, sharpness λ/(4|o·g|) (sg: 3 sub-lobes, anisotropic)
    "warp3": (("SPEC_SUBLOBES", 1),),
    # eq 41 / 43: C* ⊗ ρ*_s (sg: each sub-lobe times its expected clamped cosine)
    "spec_cosine": (("W09_CSTAR_SPEC", 1),),
    # SG NDF lobes only (sg: the fit's ASG lobes when it wrote them)
    "asg": (("W09_NO_ASG", 1),),
    # eq 47–49 with the printed coefficients (sgpipe.core.fh.PUBLISHED_FH_COEFFS, plain
    # numbers: the config imports this module), not renormalised at π/2 nor capped
    # (sg: render.fh, renormalised and capped at the lobe's integral)
    "fh": (("W09_FH_RAW", 1), ("FH_TABLE", None),
           *zip(("FH_A", "FH_C3", "FH_C2", "FH_C1", "FH_C0"),
                (1.05, 0.204, -0.892, 2.995, 0.067))),
    # eq 31 for the environment: the lobe's amplitude scaled by f̂_h, its centre and sharpness
    # kept (sg: the visible part's L2-closest lobe, core.fh_clip)
    "clip": (("W09_NO_CLIP", 1),),
    # eq 42–43 for every light (sg: lights sharper than λ 64 as E max(0, n·l) f̂_h)
    "sharp_lights": (("SHARP_LIGHT", 1e30),),
    # the lobes for the point set and sharp lights (sg: the exact BRDF from the NDF table)
    "exact_brdf": (("W09_NO_EXACT", 1),),
    # the lobes' energy as they give it (sg: each warped sub-lobe the lobe's exact warped
    # mass, and the environment's specular scaled per view to the exact directional albedo of
    # GGX materials, render.energy)
    "energy": (("SG_NO_ENERGY", 1),),
}

#: What makes `gmm_toral19` Töral19 §IV–V as published, one entry per sgpipe improvement that
#: `gmm` has over the paper: its compile-time defines, and for `points` and `fit` what the
#: renderer binds (Renderer.method_bindings). `render.gmm_toral19_adds` names improvements to give
#: back — all of them make it `gmm` (a test checks); one at a time, the ablation ladder of
#: docs/results/toral19.md.
TORAL19_SWITCHES: dict[str, tuple[tuple[str, object], ...]] = {
    # eq 9–11: the dual-paraboloid MIP chain and its distortion 4b²(|i_z| + 1)²
    # (gmm: the cube's box chain with the exact texel solid angle)
    "cube_chain": (("GMM_DP", 1),),
    # eq 10: one trilinear lookup at the lobe's level (gmm: render.gmm_taps taps over the lobe)
    "taps": (("GMM_TAPS", 1),),
    # the whole map through the chain (gmm: render.gmm_points, the point set summed exactly
    # beside the chain of the rest)
    "points": (),
    # §V: the nearest view's lobes as fitted (gmm: render.gmm_carry)
    "carry": (("GMM_ROTATE", 0),),
    # §V: 8 lobes per view for every BRDF, views fitted independently, the nearest view
    # (gmm: fit.view_gmm as configured: 24 lobes for anisotropic BRDFs, coherent fits
    # interpolated when fit.view_gmm.coherent)
    "fit": (),
}

#: What makes `transport_green06` render Green06 §5 as published, one entry per sgpipe
#: improvement that `transport`'s kernel has over the paper (its compile-time defines).
#: `render.transport_green06_adds` names improvements to give back — all of them make it
#: `transport` (a test checks). The fit is the transport stage's either way (Green06's own:
#: transport.sampling: cube).
GREEN06_SWITCHES: dict[str, tuple[tuple[str, object], ...]] = {
    # §5: the environment's glossy part is Σ w Γ_L(μ, 1/σ²) of the blended Gaussians
    # (transport: the BRDF's own lobes at the pixel × the shadowed / unshadowed Gaussians'
    # ratio under the same light, with transport.sampling: lobe)
    "ratio": (("TP_NO_RATIO", 1),),
    # §5: suns and sharp lights through the Gaussians, w·G(c)·E (transport: the exact specular
    # BRDF at their direction from the NDF table, with the SSDF horizon)
    "exact_lights": (("TP_GAUSSIAN_POINTS", 1),),
}

#: What makes `vmf_han07` Han07 §7–8 as published, one entry per sgpipe improvement that `vmf`
#: has over the paper (its compile-time defines). `render.vmf_han07_adds` names improvements to
#: give back — all of them make it `vmf` (a test checks). Both read the normal-map stage's
#: pyramids as configured (Han07's own: normalmap.bilinear_samples: 1, the texels' normals).
HAN07_SWITCHES: dict[str, tuple[tuple[str, object], ...]] = {
    # (the environment's switches first: its SH at l* = 8 swamps every other difference)
    # §8 eq 26: the environment's specular part through the reparameterised lighting's SH,
    # l* = 8, on a 16 × 16 table of views (vmf: each lobe warped to three sub-lobes through the
    # Γ_L pyramid with the lobe-mean Fresnel and masking, the point set shaded exactly)
    "env_specular": (("NM_PUB_SH_SPECULAR", 1),),
    # §8 eq 25: the environment's diffuse part through its SH, l ≤ 2, per lobe (vmf: the SG
    # light sum at the heaviest lobes' axes and the rest of the mean normal, SSDF-shadowed)
    "env_diffuse": (("NM_PUB_SH_DIFFUSE", 1),),
    # eq 24 at level 0 too: the texels' delta lobes blended (vmf: bilinear-normal taps, as the
    # map is read at full resolution)
    "level0": (("NM_PUB_L0_BLEND", 1),),
    # Algorithm 2: the trilinear MIP lookup of α_j, α_j·r_j (vmf: render.normalmap_footprint,
    # the pixel's box over the level's texels with every texel's lobes kept apart)
    "box": (("NM_PUB_TRILINEAR", 1),),
}

#: What makes `nm_sh_han07` Han07 §5 as published, one entry per sgpipe improvement that
#: `nm_sh` has over the paper (its compile-time defines; `render.nm_sh_han07_adds`). The
#: published variant needs normalmap.sh_order ≥ ⌈√(4s)⌉ (the render stage says so).
HAN07_SH_SWITCHES: dict[str, tuple[tuple[str, object], ...]] = {
    # the trilinear MIP lookup of γ_lm (nm_sh: render.normalmap_footprint's box)
    "box": (("NM_PUB_TRILINEAR", 1),),
    # level 0's γ_lm = Y_lm(n) blended as every level's (nm_sh: the bare material at the
    # bilinear normal, a delta NDF that l ≤ l* cannot hold)
    "level0": (("NM_PUB_L0_BLEND", 1),),
    # §5: eq 12 truncated at l* ≈ √(4s) (nm_sh: every band the pyramid stores)
    "bands": (("NM_PUB_SH_LSTAR", 1),),
}


def every_define(switches: dict) -> tuple[tuple[str, object], ...]:
    """A switch table's defines, all of them: what its published variant compiles with."""
    return tuple(d for ds in switches.values() for d in ds)


#: Each published variant's switch table, by method name.
PUBLISHED_SWITCHES = {"sg_wang09": WANG09_SWITCHES, "gmm_toral19": TORAL19_SWITCHES,
                      "transport_green06": GREEN06_SWITCHES, "vmf_han07": HAN07_SWITCHES,
                      "nm_sh_han07": HAN07_SH_SWITCHES}

#: The Han07 normal-map methods (stable names: the figures build on them).
NORMALMAP_METHODS = ("vmf", "normals_mip", "toksvig", "engine_bake", "nm_sh", "vmf_han07",
                     "nm_sh_han07")

#: the normal-map kernels: the pyramids, and the material's NDF lobes (MAX_NDF_LOBES) for the
#: bare material's environment specular through the `sg` method's lobes (nm_terms_body.h)
NM_KERNEL = {"needs_normalmap": True, "defines": ("MAX_NDF_LOBES",)}

METHODS: dict[str, Method] = {m.name: m for m in (
    Method("sg", "Wang09 SG + SSDF shadows", "sg_shade",
           (PIXEL_PARAMS, SG_PARAMS, TAIL_PARAMS), defines=("MAX_NDF_LOBES",),
           needs_ndf_table=True),
    # Wang09 §7 as published: sg's kernel with every switch of WANG09_SWITCHES (docs/WANG09.md)
    Method("sg_wang09", "Wang09 as published (isotropic warp, C* ⊗ ρ*_s, published f_h)",
           "sg_shade", (PIXEL_PARAMS, SG_PARAMS, TAIL_PARAMS), defines=("MAX_NDF_LOBES",),
           needs_ndf_table=True,    # read only with exact_brdf given back
           fixed_defines=every_define(WANG09_SWITCHES)),
    Method("gmm", "Töral19 per-view vMF mixtures with MIP lookups", "gmm_shade",
           (PIXEL_PARAMS, MIP_PARAMS, GMM_CHAIN_PARAMS, "const int interp", TAIL_PARAMS),
           defines=("MAX_GMM_LOBES", "GMM_TAPS", "GMM_ROTATE"), baseline_shadows=True,
           needs_view_gmm=True),
    # Töral19 as published: gmm's kernel with every switch of TORAL19_SWITCHES (docs/TORAL19.md)
    Method("gmm_toral19", "Töral19 as published (8 lobes, nearest view, one dual-paraboloid "
           "MIP lookup per lobe)", "gmm_shade",
           (PIXEL_PARAMS, MIP_PARAMS, GMM_CHAIN_PARAMS, "const int interp", TAIL_PARAMS),
           defines=("MAX_GMM_LOBES", "GMM_TAPS", "GMM_ROTATE"), baseline_shadows=True,
           needs_view_gmm=True,
           fixed_defines=every_define(TORAL19_SWITCHES)),
    Method("fis", "Colbert–Křivánek filtered importance sampling", "fis_shade",
           (PIXEL_PARAMS, MIP_PARAMS, "const int nsamp, const uint seed", TAIL_PARAMS),
           defines=("MAX_NDF_LOBES",), baseline_shadows=True, needs_ndf_table=True),
    Method("transport", "Green06 per-vertex view-dependent Gaussians + SH diffuse PRT",
           "transport_shade", (PIXEL_PARAMS, TRANSPORT_PARAMS, TAIL_PARAMS),
           defines=("MAX_NDF_LOBES",), needs_transport=True, needs_ndf_table=True),
    # Green06 §5 as published: transport's kernel with every switch of GREEN06_SWITCHES
    Method("transport_green06", "Green06 §5 as published (the blended Gaussians against the "
           "whole environment and every light)", "transport_shade",
           (PIXEL_PARAMS, TRANSPORT_PARAMS, TAIL_PARAMS), defines=("MAX_NDF_LOBES",),
           needs_transport=True, needs_ndf_table=True,
           fixed_defines=every_define(GREEN06_SWITCHES)),
    Method("vmf", "Han07 vMF-filtered normal map (Algorithm 2, eq 20–21 lights, eq 24–26 "
           "environment)", "vmf_shade", (PIXEL_PARAMS, NM_PARAMS, TAIL_PARAMS), **NM_KERNEL),
    # Han07 §7–8 as published: vmf's kernel with every switch of HAN07_SWITCHES (docs/HAN07.md)
    Method("vmf_han07", "Han07 as published (trilinear eq 24 lookup, eq 20–21 lights, §8 SH "
           "environment at l* = 8)", "vmf_shade", (PIXEL_PARAMS, NM_PARAMS, TAIL_PARAMS),
           fixed_defines=every_define(HAN07_SWITCHES), **NM_KERNEL),
    Method("normals_mip", "normalised MIP of the normal map (Han07 baseline)", "nmip_shade",
           (PIXEL_PARAMS, NM_PARAMS, TAIL_PARAMS), **NM_KERNEL),
    Method("toksvig", "Toksvig-scaled exponent (roughness) from the MIP normal length",
           "toksvig_shade", (PIXEL_PARAMS, NM_PARAMS, TAIL_PARAMS), **NM_KERNEL),
    Method("engine_bake", "engine roughness bake: one lobe, κ from the MIP normal length, "
           "α′ = √(α² + 2/κ)", "bake_shade", (PIXEL_PARAMS, NM_PARAMS, TAIL_PARAMS),
           **NM_KERNEL),
    Method("nm_sh", "Han07 §5 SH-filtered normal map (eq 12: γ_lm × ρ̂_l)", "nmsh_shade",
           (PIXEL_PARAMS, NM_PARAMS, TAIL_PARAMS), **NM_KERNEL),
    # Han07 §5 as published: nm_sh's kernel with every switch of HAN07_SH_SWITCHES
    Method("nm_sh_han07", "Han07 §5 as published (trilinear γ_lm, eq 12 at l* = ⌈√(4s)⌉)",
           "nmsh_shade", (PIXEL_PARAMS, NM_PARAMS, TAIL_PARAMS),
           fixed_defines=every_define(HAN07_SH_SWITCHES), **NM_KERNEL),
)}

#: `render.methods` choices: the OpenCL methods and the Monte Carlo ground truth.
REFERENCE = "reference"
METHOD_NAMES: tuple[str, ...] = (*METHODS, REFERENCE)


#: The kernels the renderer runs beside the methods (not choices of `render.methods`): the
#: emitted radiance of every pixel's surface, which the render stage adds to each OpenCL
#: method's image.
AUX_KERNELS: dict[str, Method] = {m.name: m for m in (
    Method("emission", "gltf_pbr emission × emissive texture", "emit_shade",
           (PIXEL_PARAMS, TAIL_PARAMS)),
)}

#: Every kernel the renderer builds, by name: the methods and the auxiliary kernels.
KERNELS: dict[str, Method] = {**METHODS, **AUX_KERNELS}


def methods_header() -> str:
    """C source of `methods.h`: `<KERNEL>_ARGS`, each kernel's parameter list."""
    lines = ["/* generated by sgpipe.render.methods.methods_header: kernel parameter lists */",
             "#ifndef SGPIPE_METHODS_H", "#define SGPIPE_METHODS_H"]
    for m in KERNELS.values():
        decls = [f"{t} {n}" if not t.endswith("*") else f"{t}{n}" for t, n in m.parameters]
        lines.append(f"#define {m.kernel.upper()}_ARGS \\\n    " + ", \\\n    ".join(decls))
    return "\n".join(lines + ["#endif", ""])
