/* Wang09 §7's specular side shared by `sg` and `transport`: the BRDF slice ρ*_s as warped,
 * cosine-weighted sub-lobes of the material's NDF lobes (or ASG lobes), through the SSDF
 * visibility (eq 31, or the clipped lobes of clip.h) and the Γ_L chain (eq 35), and the local
 * lights (eq 43). Defines: SPEC_SUBLOBES (3, or 1 = Wang09's isotropic warp), MAX_NDF_LOBES,
 * W09_NO_ASG, W09_CSTAR_SPEC and W09_NO_CLIP (sg_wang09's switches, sg_shade.cl). Needs sg.h,
 * asg.h, ssdf.h, cubemap.h, microfacet.h and shading.h first. */
#ifndef SGPIPE_SG_SPECULAR_H
#define SGPIPE_SG_SPECULAR_H

#include "clip.h"

#define SHARP_CACHE 4       /* sharp lights whose irradiance is computed once per pixel */
#ifndef SPEC_SUBLOBES
#define SPEC_SUBLOBES 3
#endif

/* E[max(0, u)], u = p·z over the normalised lobe of sharpness λ whose axis makes cos c with
 * z, taken as Gaussian with the lobe's exact mean m = c·A(λ) (A = coth λ − 1/λ) and variance
 * v = c²(1 − 2A/λ) + (1 − c²)A/λ − m²: mΦ(m/σ) + σφ(m/σ); *phi gets Φ(m/σ). */
inline float sg_clamped_cos_mean(float c, float lam, float *phi) {
    float s2 = fmax(1.0f - c * c, 0.0f);
    float A = mean_resultant(lam);
    float b = A / lam;
    float mu_u = c * A;
    float sd = sqrt(fmax(c * c * (1.0f - 2.0f * b) + s2 * b - mu_u * mu_u, 0.0f)) + 1e-7f;
    float z = mu_u / sd;
    *phi = half_erfc(-0.70710678f * z);
    return mu_u * *phi + sd * 0.39894228f * exp(-0.5f * z * z);
}

/* G(i; p, λ, μ)·max(0, i·z) ≈ E[max(0, u)]·G(i; p', λ, μ) (replaces C* ⊗ G of eq 41, whose ±17 %
 * shape error dominated sharp lobes): E[max(0, u)] of sg_clamped_cos_mean, and p' is p tilted
 * towards z by the cosine-weighted mean offset δ = √(1 − c²)/λ · Φ(m/σ)/E[max(0, u)] (Stein). */
inline SG spec_cosine(SG g) {
    float c = clamp(g.p.z, -1.0f, 1.0f);
    float s2 = fmax(1.0f - c * c, 0.0f);
    float Phi;
    float eu = sg_clamped_cos_mean(c, g.lam, &Phi);
    float delta = eu > 1e-12f ? sqrt(s2) / g.lam * Phi / eu : 0.0f;
    float3 nt = (float3)(0.0f, 0.0f, 1.0f) - c * g.p;
    float ln = length(nt);
    float3 p = ln > 1e-7f ? normalize(g.p + (delta / ln) * nt) : g.p;   /* tilt by atan δ ≈ δ */
    return sg_make(p, g.lam, g.mu * eu);
}

/* Wang09 eq 17–20 with the warp's anisotropy kept: an NDF lobe G(h; g, λ, μ) seen from o maps
 * to i-space around p = reflect(o, g) with sharpness λ/4 in the plane of incidence and
 * λ/(4(o·g)²) across it (Jacobian of h = (o + i)/‖o + i‖; Wang09's isotropic λ/(4|o·g|) is
 * their geometric mean). SPEC_SUBLOBES = 3: Gauss–Hermite sum of three isotropic lobes of the
 * across sharpness, at 0, ±√3·σ_s along the plane (σ_s² = 4(1 − (o·g)²)/λ), weights 1/6, 2/3,
 * 1/6 over o·g (same integral); SPEC_SUBLOBES = 1: Wang09's isotropic lobe. */
inline void spec_warp(SG g, float3 o, SG *sub, int exact_mass) {
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
    if (exact_mass) a = fmin(a, 1.5707963f);
    float2 sc = sincos_small(a);
    float ca = sc.y, sa = sc.x;
    /* exact_mass (GGX materials with an energy table, MAT_WARPN): the sub-lobes carry the
     * warped lobe's integral ∫ G(h) |∂i/∂h| dh = 4 I(λ) E[max(0, o·h)] (I: the SG integral),
     * which is I(λ_x)·μ/(o·g) for a narrow lobe; with μ/(o·g), a broad lobe (rough GGX) gains
     * that 1/(o·g) at grazing views (×20 at o·g = 0.05), and its side sub-lobes stay ≤ 90° off */
    float phi;
    float3 mu = exact_mass ? w.mu * (4.0f * sg_integral_unit(g.lam)
                                     * sg_clamped_cos_mean(og, g.lam, &phi)
                                     / sg_integral_unit(lam_x))
                           : w.mu / og;
    sub[0] = sg_make(w.p, lam_x, mu * (2.0f / 3.0f));
    sub[1] = sg_make(normalize(ca * w.p + sa * ea), lam_x, mu * (1.0f / 6.0f));
    sub[2] = sg_make(normalize(ca * w.p - sa * ea), lam_x, mu * (1.0f / 6.0f));
#else
    sub[0] = w;
#endif
}

/* The material's energy factor per channel at view elevation cos_o (render.energy): per view
 * (a1, a2, s1, s2), the exact albedo and the lobes' white-furnace response for F ≡ 1 and for
 * F = (1 − o·h)⁵, linear in cos θ_o — the material's table, or for a textured pixel (MAT_SV)
 * its roughness grid's, bilinear over (view, grid entry) — then (F0 a1 + (1 − F0) a2) /
 * (F0 s1 + (1 − F0) s2) with Schlick's F0 (a1 / s1 for another Fresnel); 1 without a table. */
inline float3 sg_energy(__global const float *m, __global const float *tables, float cos_o) {
#ifdef SG_NO_ENERGY
    return (float3)(1.0f);
#else
    float x = (clamp(cos_o, ENERGY_COS_MIN, 1.0f) - ENERGY_COS_MIN) / (1.0f - ENERGY_COS_MIN)
              * (float)(ENERGY_VIEWS - 1);
    int v0 = min((int)floor(x), ENERGY_VIEWS - 2);
    float fv = x - (float)v0;
    float4 e;
    if (m[MAT_SV] > 0.5f) {
        if (m[MAT_ETGRID] < 0.0f || m[MAT_SVLOB] < 0.0f) return (float3)(1.0f);
        int ne = (int)m[MAT_SVN];
        int e0 = (int)((m[MAT_LOBE0] - m[MAT_SVLOB]) / m[MAT_SVSTEP] + 0.5f);
        int e1 = min(e0 + 1, ne - 1);
        float fe = m[MAT_SVFRAC];
        __global const float4 *t = (__global const float4 *)(tables + (int)m[MAT_ETGRID]);
        e = mix(mix(t[v0 * ne + e0], t[v0 * ne + e1], fe),
                mix(t[(v0 + 1) * ne + e0], t[(v0 + 1) * ne + e1], fe), fv);
    } else {
        if (m[MAT_ETAB] < 0.0f) return (float3)(1.0f);
        __global const float4 *t = (__global const float4 *)(tables + (int)m[MAT_ETAB]);
        e = mix(t[v0], t[v0 + 1], fv);
    }
    if ((int)m[MAT_FRESNEL] != 1) return (float3)(e.x / fmax(e.z, 1e-6f));
    float3 f0 = mat3(m, MAT_F0);
    return (f0 * e.x + (1.0f - f0) * e.y) / fmax(f0 * e.z + (1.0f - f0) * e.w, 1e-6f);
#endif
}

/* Σ over the material's lobes of its specular sub-lobes (spec_warp / asg.h, × M_o, spec_cosine
 * or C* ⊗ under W09_CSTAR_SPEC) against the environment (`env`: ⊗ V^d (eq 31), rotated to world,
 * Γ_L (eq 41 / 35); the point set's Gaussians too unless `exact_pts`, whose caller adds them
 * exactly) and the local lights (eq 43; sharp lights as w(l)·E with E from e_sharp for the
 * first SHARP_CACHE, skipped when `ndf_has`: the caller adds them exactly). op: the view in
 * the normal-mapped frame, q / qi that rotation; vis: the SSDF state (a Vis without SSDF
 * keeps only the tangent plane's horizon); nm_kappa > 0: the NDF lobes convolved with that
 * vMF (a filtered normal-map lobe, ndf_lobe; 0: none). */
inline float3 sg_lobes_specular(__global const float *m, __global const float4 *lobes,
                                __global const float *tables, float3 ks, float3 op,
                                float4 q, float4 qi, float3 T, float3 B, float3 N, float3 x,
                                const Vis *vis, int env, int exact_pts, int ndf_has,
                                __global const float4 *pyr, __global const int *pyr_off,
                                __global const int *pyr_res, __global const float *pyr_lam,
                                int pyr_n, float pyr_log_ratio, float4 env_mean,
                                __global const float4 *pyr_raw, int raw_n,
                                __global const float4 *pyr_pts, int n_pts, float env_scale,
                                __global const float4 *lights, int n_lights,
                                const float3 *e_sharp, float nm_kappa) {
    float3 rs = (float3)(0.0f), renv = (float3)(0.0f);
#ifdef W09_CSTAR_SPEC
    SG cosq = sg_clamped_cosine((float3)(0.0f, 0.0f, 1.0f));   /* C*(z+) of the rotated frame */
#endif
    int nsg = (int)m[MAT_NLOBES], lobe0 = (int)m[MAT_LOBE0];
#ifdef W09_NO_ASG
    int na = 0;
#else
    int na = asg_count(lobes, lobe0, nsg);
#endif
    int nl = na > 0 ? 0 : min(nsg, MAX_NDF_LOBES);
    /* do the lights reach the sub-lobes at all? (a sharp light with the NDF table is the
     * caller's, exactly): once per pixel rather than per sub-lobe */
    int lobe_lights = 0;
    for (int l = 0; l < n_lights && !lobe_lights; ++l)
        lobe_lights = !ndf_has || light_sg(lights[2 * l], lights[2 * l + 1], x).lam < SHARP_LIGHT;
    if (!env && !lobe_lights) return rs;
    GammaPlan gp;                  /* Γ_L's plan for the sharpness gp_lam */
    float gp_lam = -1.0f;
    for (int j = 0; j < nl + na; ++j) {
        SG sub[SPEC_SUBLOBES];
        ASGPlan plan;
        int nsub = SPEC_SUBLOBES;
        if (j < nl) {
            float4 L0, L1;
            ndf_lobe(lobes, m, j, nm_kappa, &L0, &L1);
#ifdef SG_NO_ENERGY
            spec_warp(sg_make(normalize(L0.xyz), L0.w, (float3)(L1.x)), op, sub, 0);
#else
            spec_warp(sg_make(normalize(L0.xyz), L0.w, (float3)(L1.x)), op, sub, 1);
#endif
        } else {
            int a = lobe0 + nsg + 1 + (j - nl);
            plan = asg_plan(lobes[2 * a], lobes[2 * a + 1], op);
            nsub = asg_sublobe_count(&plan);
        }
        /* the SSDF is decoded once per NDF lobe (its centre sub-lobe); the side sub-lobes,
         * offset in the plane of incidence, take θ_d shifted by their change of elevation
         * (exact for the horizon) */
        float th0 = 0.0f, el0 = 0.0f;
#ifndef W09_NO_CLIP
        float3 g0 = (float3)(0.0f);       /* θ_d's gradient at the first clipped sub-lobe */
        int has_g0 = 0;
#endif
        for (int k = 0; k < nsub; ++k) {
            SG w;
            if (j < nl) w = sub[k];
            else if (!asg_sublobe(&plan, k, &w)) continue;
#ifdef W09_CSTAR_SPEC
            w.mu *= mf_M(m, tables, ks, op, lift(w.p, 0.05f));
            SG s = sg_product(w, cosq);              /* C* ⊗ ρ*_s, eq 41 / 43 */
#else
            /* M_o at the sub-lobe's axis kept min(σ, 0.5) above the horizon (σ = 1/√λ, at
             * least 0.05): a broad lobe's axis near or below it is no direction the lobe's
             * mass comes from, and M_o's 1/(n·i) there multiplied the whole lobe (×20) */
            w.mu *= mf_M(m, tables, ks, op,
                         lift(w.p, fmax(0.05f, fmin(rsqrt(w.lam), 0.5f))));
            SG s = spec_cosine(w);
#endif
            w.p = quat_rotate(q, w.p);
            s.p = quat_rotate(q, s.p);
            /* Environment (eq 41): ⊗ V^d (eq 31), rotate to world, Γ_L lookup (eq 35); the
             * point set's Gaussians below e^{−16} skipped (asg_points): a sharp sub-lobe sees
             * few points, and one exp per point and sub-lobe is as dear as the lookup. */
            if (env) {
                float el = asin(clamp(s.p.z, -1.0f, 1.0f));
                if (k == 0) { th0 = vis_theta(vis, s.p); el0 = el; }
                float th = clamp(th0 + (el - el0), -1.5707963f, 1.5707963f);
#ifdef W09_NO_CLIP
                SG sv = sg_times_visibility(s, th);
#else
                SG sv;
                if (clip_none(th, s.lam)) {
                    sv = sg_times_visibility(s, th);
                } else {
                    /* one gradient per NDF lobe, carried to each sub-lobe's tangent plane */
                    if (!has_g0) { g0 = vis_gradient(vis, s.p, th); has_g0 = 1; }
                    float3 g = g0 - dot(g0, s.p) * s.p;
                    float lg = length(g);
                    g = lg > 1e-6f ? g / lg : vis_gradient(vis, s.p, th);
                    sv = sg_clip_visible(s, th, g);
                }
#endif
                float3 pw = normalize(to_world(sv.p, T, B, N));
                if (sv.lam != gp_lam) {     /* unclipped sub-lobes share their λ */
                    gp = gamma_plan(pyr_lam, pyr_n, pyr_log_ratio, raw_n, sv.lam);
                    gp_lam = sv.lam;
                }
                renv += sv.mu * env_scale * (gamma_lookup_plan(pyr, pyr_off, pyr_res, pyr_n,
                                                             env_mean.xyz, pyr_raw, raw_n, pw,
                                                             &gp)
                                           + (exact_pts ? (float3)(0.0f)
                                                        : asg_points(pyr_pts, n_pts, pw, sv.lam)));
            }
            /* Local lights (eq 43). */
            for (int l = 0; l < (lobe_lights ? n_lights : 0); ++l) {
                SG Lw = light_sg(lights[2 * l], lights[2 * l + 1], x);
                SG L = sg_make(to_local(Lw.p, T, B, N), Lw.lam, Lw.mu);
                if (L.lam >= SHARP_LIGHT) {
                    if (ndf_has) continue;          /* exact: the caller's */
                    float3 E;
                    if (l < SHARP_CACHE) {
                        E = e_sharp[l];
                    } else {
                        float3 lp = quat_rotate(qi, L.p);
                        if (lp.z <= 0.0f || L.p.z <= 0.0f) continue;
                        E = sg_integral(L) * (lp.z * fh_hat(vis_theta(vis, L.p), L.lam));
                    }
                    rs += sg_eval(w, L.p) * E;
                    continue;
                }
                SG sl = sg_product(L, s);
                rs += sg_dot_visibility(sl, vis_theta(vis, sl.p));
            }
        }
    }
    /* the environment's part scaled to the BRDF's exact energy at this view (render.energy) */
    return rs + (env ? sg_energy(m, tables, op.z) : 1.0f) * renv;
}

#endif
