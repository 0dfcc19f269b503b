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

#ifndef SPEC_SUBLOBES
#define SPEC_SUBLOBES 3
#endif
#define SHARP_CACHE 4       /* sharp lights whose irradiance is computed once per pixel */

/* Wang09 eq 17–20 with the warp's anisotropy kept: an NDF lobe G(h; g, λ, μ) seen from o maps
 * to i-space around p = reflect(o, g) with sharpness λ/4 in the plane of incidence and
 * λ/(4(o·g)²) across it (Jacobian of h = (o + i)/‖o + i‖; Wang09's isotropic λ/(4|o·g|) is
 * their geometric mean). SPEC_SUBLOBES = 3: Gauss–Hermite sum of three isotropic lobes of the
 * across sharpness, at 0, ±√3·σ_s along the plane (σ_s² = 4(1 − (o·g)²)/λ), weights 1/6, 2/3,
 * 1/6 over o·g (same integral); SPEC_SUBLOBES = 1: Wang09's isotropic lobe. */
inline void spec_warp(SG g, float3 o, SG *sub) {
    SG w = sg_warp(g, o);
#if SPEC_SUBLOBES == 3
    float og = fmax(fabs(dot(o, g.p)), 1e-3f);
    float lam_x = g.lam / (4.0f * og * og);
    float sig = sqrt(fmax(4.0f * (1.0f - og * og) / g.lam, 0.0f));
    float3 ex = cross(o, g.p);
    float le = length(ex);
    ex = le > 1e-7f ? ex / le : (float3)(1.0f, 0.0f, 0.0f);
    float3 ea = normalize(cross(w.p, ex));    /* in the plane of incidence, ⊥ p */
    float a = 1.7320508f * sig;
    float ca = cos(a), sa = sin(a);
    float3 mu = w.mu / og;
    sub[0] = sg_make(w.p, lam_x, mu * (2.0f / 3.0f));
    sub[1] = sg_make(normalize(ca * w.p + sa * ea), lam_x, mu * (1.0f / 6.0f));
    sub[2] = sg_make(normalize(ca * w.p - sa * ea), lam_x, mu * (1.0f / 6.0f));
#else
    sub[0] = w;
#endif
}

/* G(i; p, λ, μ)·max(0, i·z) ≈ E[max(0, u)]·G(i; p', λ, μ) (replaces C* ⊗ G of eq 41, whose ±17 %
 * shape error dominated sharp lobes): u = i·z over the normalised lobe taken as Gaussian with
 * the lobe's exact mean m = c·A(λ) (c = p·z, A = coth λ − 1/λ) and variance
 * v = c²(1 − 2A/λ) + (1 − c²)A/λ − m², so E[max(0, u)] = mΦ(m/σ) + σφ(m/σ); p' is p tilted
 * towards z by the cosine-weighted mean offset δ = √(1 − c²)/λ · Φ(m/σ)/E[max(0, u)] (Stein). */
inline SG spec_cosine(SG g) {
    float c = clamp(g.p.z, -1.0f, 1.0f);
    float s2 = fmax(1.0f - c * c, 0.0f);
    float A = mean_resultant(g.lam);
    float b = A / g.lam;
    float mu_u = c * A;
    float sd = sqrt(fmax(c * c * (1.0f - 2.0f * b) + s2 * b - mu_u * mu_u, 0.0f)) + 1e-7f;
    float z = mu_u / sd;
    float Phi = 0.5f * erfc(-0.70710678f * z);
    float eu = mu_u * Phi + sd * 0.39894228f * exp(-0.5f * z * z);
    float delta = eu > 1e-12f ? sqrt(s2) / g.lam * Phi / eu : 0.0f;
    float3 nt = (float3)(0.0f, 0.0f, 1.0f) - c * g.p;
    float ln = length(nt);
    float3 p = ln > 1e-7f ? normalize(g.p + (delta / ln) * nt) : g.p;   /* tilt by atan δ ≈ δ */
    return sg_make(p, g.lam, g.mu * eu);
}

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
            rs += E * mf_M(m, tables, ks, op, lp) * ndf_table(tables, ndf, normalize(op + lp));
    }
    /* Specular: per NDF lobe the BRDF slice ρ*_s(i; o') as a warped SG lobe (eq 22) split in
     * SPEC_SUBLOBES isotropic sub-lobes (anisotropic warp), each times M_o and the cosine
     * (spec_cosine), in the geometric frame; built on the fly (no per-lobe arrays: private
     * memory stays small for any MAX_NDF_LOBES). */
    int nsg = (int)m[MAT_NLOBES], lobe0 = (int)m[MAT_LOBE0];
    /* The point set (a sun) with the exact BRDF where the material has its NDF table
     * (shading.h points_exact_specular). */
    int exact_pts = ndf.w && !(flags & FLAG_NO_ENV_SPECULAR);
    if (exact_pts)
        rs += points_exact_specular(pyr_pts, n_pts, m, tables, ndf, ks, op, qi, T, B, N, &vis,
                                    env_scale);
#ifdef W09_NO_ASG
    int na = 0;
#else
    int na = asg_count(lobes, lobe0, nsg);
#endif
    int nl = na > 0 ? 0 : min(nsg, MAX_NDF_LOBES);
    for (int j = 0; j < nl + na; ++j) {
        SG sub[SPEC_SUBLOBES];
        ASGPlan plan;
        int nsub = SPEC_SUBLOBES;
        if (j < nl) {
            float4 L0 = lobes[2 * (lobe0 + j)];
            float4 L1 = lobes[2 * (lobe0 + j) + 1];
            spec_warp(sg_make(normalize(L0.xyz), L0.w, (float3)(L1.x)), op, sub);
        } else {
            int a = lobe0 + nsg + 1 + (j - nl);
            plan = asg_plan(lobes[2 * a], lobes[2 * a + 1], op);
            nsub = asg_sublobe_count(&plan);
        }
        /* the SSDF is decoded once per NDF lobe (its centre sub-lobe); the side sub-lobes,
         * offset in the plane of incidence, take θ_d shifted by their change of elevation
         * (exact for the horizon) */
        float th0 = 0.0f, el0 = 0.0f;
        for (int k = 0; k < nsub; ++k) {
            SG w;
            if (j < nl) w = sub[k];
            else if (!asg_sublobe(&plan, k, &w)) continue;
            w.mu *= mf_M(m, tables, ks, op, lift(w.p, 0.05f));
#ifdef W09_CSTAR_SPEC
            SG s = sg_product(w, cosq);              /* C* ⊗ ρ*_s, eq 41 / 43 */
#else
            SG s = spec_cosine(w);
#endif
            w.p = quat_rotate(q, w.p);
            s.p = quat_rotate(q, s.p);
            /* Environment (eq 41): ⊗ V^d (eq 31), rotate to world, Γ_L lookup (eq 35); the
             * point set's Gaussians below e^{−16} skipped (asg_points): a sharp sub-lobe sees
             * few points, and one exp per point and sub-lobe is as dear as the lookup. */
            if (!(flags & FLAG_NO_ENV_SPECULAR)) {
                float el = asin(clamp(s.p.z, -1.0f, 1.0f));
                if (k == 0) { th0 = vis_theta(&vis, s.p); el0 = el; }
                float th = clamp(th0 + (el - el0), -1.5707963f, 1.5707963f);
                SG sv = sg_times_visibility(s, th);
                float3 pw = normalize(to_world(sv.p, T, B, N));
                rs += sv.mu * env_scale * (gamma_lookup_acc(pyr, pyr_off, pyr_res, pyr_lam,
                                                            pyr_n, pyr_log_ratio, env_mean.xyz,
                                                            pyr_raw, raw_n, pw, sv.lam)
                                           + (exact_pts ? (float3)(0.0f)
                                                        : asg_points(pyr_pts, n_pts, pw, sv.lam)));
            }
            /* Local lights (eq 43). */
            for (int l = 0; l < n_lights; ++l) {
                SG Lw = light_sg(lights[2 * l], lights[2 * l + 1], x);
                SG L = sg_make(to_local(Lw.p, T, B, N), Lw.lam, Lw.mu);
                if (L.lam >= SHARP_LIGHT) {
                    if (ndf.w) continue;            /* exact above */
                    float3 E;
                    if (l < SHARP_CACHE) {
                        E = e_sharp[l];
                    } else {
                        float3 lp = quat_rotate(qi, L.p);
                        if (lp.z <= 0.0f || L.p.z <= 0.0f) continue;
                        E = sg_integral(L) * (lp.z * fh_hat(vis_theta(&vis, L.p), L.lam));
                    }
                    rs += sg_eval(w, L.p) * E;
                    continue;
                }
                SG sl = sg_product(L, s);
                rs += sg_dot_visibility(sl, vis_theta(&vis, sl.p));
            }
        }
    }
    out[gid] = (float4)(rd + rs, 1.0f);
}
