/* Method `sg`: Wang09 §7 full shading of G-buffer pixels.
 *   diffuse   R_d = Σ_k f_d · (C* ⊗ L*_k) · V^d                  (eq 39)
 *   specular  R_s = Σ_j ((cos ⊗ ρ*_s,j ⊗ V^d) · L) via Γ_L          (eq 41, warp eq 22)
 *   lights    (L*_x ⊗ C*) · V^d and (L*_x ⊗ cos ⊗ ρ*_s) · V^d      (eq 42–43, lights eq 32–33)
 * with per-pixel SSDF decoding from interpolated PCA coefficients (eq 24, 30–31) and normal
 * maps as quaternion rotations of C* and ρ*_s (§7). Departures from the paper that remove its
 * largest errors on glossy materials (measured on the studio Ward sphere, see spec_warp /
 * spec_cosine): ρ*_s keeps the warp's anisotropy (3 isotropic sub-lobes per NDF lobe, M_o at
 * each), the cosine multiplies each sub-lobe by its Gaussian-expected clamped value instead of
 * C* ⊗, and Γ_L uses the accurate pyramid path (B-spline in p, Hermite of ln Γ_L in ln λ).
 * Defines: NV (PCA terms, stride of the coefficient rows), FH_A, FH_C3..FH_C0 (f_h sigmoid),
 * MAX_NDF_LOBES, SPEC_SUBLOBES (3, or 1 = Wang09's isotropic warp), ASG_MAX_HALF (asg.h).
 * A material with ASG lobes (fit.ndf_sg.anisotropic: asg) is shaded from them instead of its SG
 * lobes: each ASG's i-space sub-lobes (asg.h) go through the same M_o, cosine, SSDF and Γ_L.
 * The environment's point set (a sun) and lights sharper than SHARP_LIGHT are shaded with the
 * exact BRDF M_o(i) D(h) (the NDF table of materials.tabulate_ndf, as `fis` reads it) at their
 * direction, SSDF horizon, not through the lobes, whenever the material has that table.
 * Method `sg_wang09` (the paper as published) compiles with switches that undo each of these
 * (methods.WANG09_SWITCHES): SPEC_SUBLOBES 1; W09_CSTAR_SPEC: C* ⊗ ρ*_s (eq 41 / 43) instead of
 * spec_cosine; W09_NO_ASG: SG lobes only; W09_FH_RAW and the printed f_h coefficients: f_h as
 * eq 49 prints it (ssdf.h); SHARP_LIGHT 1e30: every light through the products; W09_NO_EXACT:
 * the point set and sharp lights through the lobes, not the NDF table. */
#include "sg.h"
#include "asg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"   /* also SHARP_LIGHT */
#include "sg_specular.h"

__kernel void sg_shade(SG_SHADE_ARGS)
{
    SHADE_PIXEL_PROLOGUE;
    SG cosq = sg_clamped_cosine((float3)(0.0f, 0.0f, 1.0f));   /* C*(z+) of the rotated frame */
    SG cosg = cosq; cosg.p = quat_rotate(q, cosq.p);             /* ... in the geometric frame */

    float3 rd = (float3)(0.0f), rs = (float3)(0.0f);
    /* Environment, diffuse (eq 39). */
    if (!(flags & FLAG_NO_ENV_DIFFUSE))
        rd += diffuse_env_sg(m, kd, op, q, qi, T, B, N, env_sg, n_env_sg, env_scale, &vis);
    /* Local lights, diffuse part (eq 42), in the local frame. A light much sharper than the
     * cosine lobe (λ_L ≥ SHARP_LIGHT) uses the limit of the products, E·max(0, n·l)·f(l)·
     * f̂_h(θ_d(l), λ_L): C*'s peak 1.17 would otherwise brighten small lights by up to 17%. */
    float3 e_sharp[SHARP_CACHE];      /* E of the first sharp lights, reused by the specular */
    /* The material's NDF table (materials.tabulate_ndf; ndf.w = 0: none): sharp lights and the
     * environment's point set then take the exact specular BRDF M_o(i) D(h) at their direction
     * instead of the lobes' value there (below). */
    int4 ndf = ndf_info[OBJ_MAT(ob)];
#ifdef W09_NO_EXACT
    ndf.w = 0;
#endif
    for (int k = 0; k < n_lights; ++k) {
        SG Lw = light_sg(lights[2 * k], lights[2 * k + 1], x);
        SG L = sg_make(to_local(Lw.p, T, B, N), Lw.lam, Lw.mu);
        float3 lp;                     /* sharp: l in the normal-mapped frame */
        float3 E = sg_light_diffuse(L, cosg, qi, &vis, &lp);
        rd += mf_diffuse(m, kd, op, lp) * E;
        if (L.lam < SHARP_LIGHT) continue;
        if (k < SHARP_CACHE) e_sharp[k] = E;
        if (ndf.w && lp.z > 0.0f)
            rs += sharp_light_specular(E, m, tables, ndf, ks, op, lp);
    }
    /* The point set (a sun) with the exact BRDF where the material has its NDF table
     * (shading.h points_exact_specular). */
    int exact_pts = ndf.w && !(flags & FLAG_NO_ENV_SPECULAR);
    if (exact_pts)
        rs += points_exact_specular(pyr_pts, n_pts, m, tables, ndf, ks, op, qi, T, B, N, &vis,
                                    env_scale);
    /* Specular: per NDF lobe the BRDF slice ρ*_s(i; o') as a warped SG lobe (eq 22) split in
     * SPEC_SUBLOBES isotropic sub-lobes (anisotropic warp), each times M_o and the cosine
     * (spec_cosine), in the geometric frame; built on the fly (no per-lobe arrays: private
     * memory stays small for any MAX_NDF_LOBES): sg_specular.h. */
    rs += sg_lobes_specular(m, lobes, tables, ks, op, q, qi, T, B, N, x, &vis,
                            !(flags & FLAG_NO_ENV_SPECULAR), exact_pts, ndf.w,
                            pyr, pyr_off, pyr_res, pyr_lam, pyr_n, pyr_log_ratio, env_mean,
                            pyr_raw, raw_n, pyr_pts, n_pts, env_scale, lights, n_lights,
                            e_sharp, 0.0f);
    out[gid] = (float4)(rd + rs, 1.0f);
}
