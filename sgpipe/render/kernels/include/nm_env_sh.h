/* Han07 §8 (`vmf_han07`): the environment through SH at l* = 8 (sgpipe/render/han07_env.py
 * builds nm_env_sh8: L_lm, then the reparameterised L'_lm on NM_SH8_VIEWS² views, map frame).
 *   diffuse  (eq 25) kd/π Σ_j α_j Σ_{l ≤ 2} Â_l e^{−l²/(2κ_j)} Σ_m L_lm Y_lm(μ_j)
 *   specular (eq 26) Σ_j α_j X_j Σ_{l ≤ 8} ρ̂_l e^{−l²/(2κ_j)} Σ_m L'_lm(o) Y_lm(μ_j), L' read
 *            bilinearly between the table's views; X_j the BRDF's factors outside ρ_eff(ω_h·μ)
 *            at the lobe's mirror direction (Blinn–Phong: ks (μ·i); microfacet: ks F G / (μ·o)).
 * e^{−l²/(2κ)} is eq 19 as printed (the vMF's SH coefficients; κ = ∞ for a single normal).
 * Unshadowed (the paper shades no visibility). */
#ifndef SGPIPE_NM_ENV_SH_H
#define SGPIPE_NM_ENV_SH_H

#define NM_SH8_L 8
#define NM_SH8_K 81
#define NM_SH8_VIEWS 16       /* han07_env.VIEWS */

/* Eq 19: the vMF's zonal SH factor at band l. */
inline float nm_vmf_band(int l, float kappa) {
    return kappa > 1e20f ? 1.0f : exp(-(float)(l * l) / (2.0f * kappa));
}

/* Eq 25: Σ_{l ≤ 2} Â_l e^{−l²/2κ} Σ_m L_lm Y_lm(μ) for a lobe about the world axis mu. */
inline float3 nm_sh8_diffuse(__global const float4 *sh8, float3 mu, float kappa) {
    const float ah[3] = {3.14159265f, 2.09439510f, 0.785398163f};
    float y[9];
    nm_sh_eval(env_to_map(mu), 2, y);
    float3 e = (float3)(0.0f);
    for (int l = 0; l <= 2; ++l) {
        float3 b = (float3)(0.0f);
        for (int k = l * l; k < (l + 1) * (l + 1); ++k) b += y[k] * sh8[k].xyz;
        e += ah[l] * nm_vmf_band(l, kappa) * b;
    }
    return e;
}

/* Eq 26: Σ_{l ≤ 8} ρ̂_l e^{−l²/2κ} Σ_m L'_lm(o) Y_lm(μ) — L' bilinear in the view table
 * (θ from the map's +z at cell centres, clamped; φ wrapped). */
inline float3 nm_sh8_specular(__global const float4 *sh8, const float *rho, float3 o,
                              float3 mu, float kappa) {
    float y[NM_SH8_K];
    nm_sh_eval(env_to_map(mu), NM_SH8_L, y);
    for (int l = 0; l <= NM_SH8_L; ++l) {
        float c = rho[l] * nm_vmf_band(l, kappa);
        for (int k = l * l; k < (l + 1) * (l + 1); ++k) y[k] *= c;
    }
    float3 om = env_to_map(o);
    const float nv = (float)NM_SH8_VIEWS;
    float th = acos(clamp(om.z, -1.0f, 1.0f)), ph = atan2(om.y, om.x);
    float fi = clamp(th / M_PI_F * nv - 0.5f, 0.0f, nv - 1.0f);
    float fj = (ph < 0.0f ? ph + 2.0f * M_PI_F : ph) / (2.0f * M_PI_F) * nv - 0.5f;
    int i0 = min((int)floor(fi), NM_SH8_VIEWS - 1), i1 = min(i0 + 1, NM_SH8_VIEWS - 1);
    float ti = fi - (float)i0;
    float fj0 = floor(fj);
    float tj = fj - fj0;
    int j0 = ((int)fj0 + NM_SH8_VIEWS) % NM_SH8_VIEWS, j1 = (j0 + 1) % NM_SH8_VIEWS;
    const int iv[4] = {i0, i0, i1, i1}, jv[4] = {j0, j1, j0, j1};
    const float wv[4] = {(1.0f - ti) * (1.0f - tj), (1.0f - ti) * tj, ti * (1.0f - tj), ti * tj};
    float3 acc = (float3)(0.0f);
    for (int c = 0; c < 4; ++c) {
        if (wv[c] <= 0.0f) continue;
        __global const float4 *t = sh8 + NM_SH8_K * (1 + iv[c] * NM_SH8_VIEWS + jv[c]);
        float3 b = (float3)(0.0f);
        for (int k = 0; k < NM_SH8_K; ++k) b += y[k] * t[k].xyz;
        acc += wv[c] * b;
    }
    return acc;
}

/* The BRDF's factors outside ρ_eff(ω_h · μ) (eq 26), at the lobe's mirror direction
 * i = 2(μ·o)μ − o: Blinn–Phong ks (μ·i), microfacet ks F(o·h) G / (μ·o) at h = μ, roughness a;
 * a measured material M_o (μ·i) (its ρ̂_l are its D*'s: normalmap_data.merl_sh_coeffs), a the
 * ratio α′/α of its lobe's convolved roughness to its own. */
inline float3 nm_sh8_factor(__global const float *m, float3 ks, int model, float3 mu, float3 o,
                            float a, __global const float *tables) {
    float co = dot(mu, o);
    if (co <= 1e-4f) return (float3)(0.0f);
    if (model == NM_BLINN) return ks * co;
    if (model == NM_MERL) {
        /* M_o·(n·i) at the mirror direction (its D* in ρ̂) with the masking of the convolved
         * lobe, as the analytic models' G at α′: the tabulated S at the angle whose tangent is
         * a (= α′/α) times the view's (Smith G1 depends on α tan θ) */
        float t = a * sqrt(fmax(1.0f - co * co, 0.0f)) / co;
        float cw = rsqrt(1.0f + t * t);
        float3 ow = (float3)(sqrt(fmax(1.0f - cw * cw, 0.0f)), 0.0f, cw);
        float G = mf_g2(m, tables, ow, (float3)(-ow.x, 0.0f, cw), (float3)(0.0f, 0.0f, 1.0f));
        return ks * mf_fresnel(m, co) * (m[MAT_GSCALE] * G * MF_INV_PI / co);
    }
    return nm_fres(m, ks, model, co) * (nm_mf_g(model, co, co, 1.0f, co, a) / co);
}

#endif
