/* The real SH basis of the normal-map kernels (nm_sh's eq 12, Han07 §8's environment):
 * evaluation, eq 12's dot product with ρ̂_l, and bands 1–2 rotated to world. Included by
 * nm_shade.h. */
#ifndef SGPIPE_NM_SH_BASIS_H
#define SGPIPE_NM_SH_BASIS_H

/* Real SH basis (sgpipe.core.sh: orthonormal, no Condon–Shortley phase, k = l(l + 1) + m) of a
 * unit direction for l ≤ lmax into y[(lmax + 1)²]. */
inline void nm_sh_eval(float3 d, int lmax, float *y) {
    float cm = 1.0f, sm = 0.0f, pmm = 1.0f;
    for (int mm = 0; mm <= lmax; ++mm) {
        if (mm > 0) {
            float c2 = cm * d.x - sm * d.y;
            sm = cm * d.y + sm * d.x;
            cm = c2;
            pmm *= (float)(2 * mm - 1);
        }
        float p2 = 0.0f, p1 = pmm;
        for (int l = mm; l <= lmax; ++l) {
            float p;
            if (l == mm) p = pmm;
            else if (l == mm + 1) p = d.z * (float)(2 * mm + 1) * pmm;
            else p = ((float)(2 * l - 1) * d.z * p1 - (float)(l + mm - 1) * p2) / (float)(l - mm);
            if (l > mm) { p2 = p1; p1 = p; }
            float r = 1.0f;                                    /* (l − m)!/(l + m)! */
            for (int k = l - mm + 1; k <= l + mm; ++k) r /= (float)k;
            float kk = sqrt((float)(2 * l + 1) * 0.0795774715459477f * r);
            if (mm == 0) {
                y[l * (l + 1)] = kk * p;
            } else {
                y[l * (l + 1) + mm] = 1.41421356f * kk * p * cm;
                y[l * (l + 1) - mm] = 1.41421356f * kk * p * sm;
            }
        }
    }
}

/* ρ̂_l (eq 11), l < NM_RHO_N, into rho: the material's (nm_brdf's ρ̂ slots) or, where the
 * object has a table over α (slot NM_RHOTAB_SLOT: 1 + its float4 offset in d; a textured glTF
 * material's) and a ≥ 0, the GGX specular function's at roughness a, linear in ln α between
 * the table's entries (header (ln α_0, Δ ln α, entries, 0), then NM_RHO_F4 float4 each). */
inline void nm_rho_at(__global const float4 *d, __global const float *bp, float a, float *rho) {
    int off = (int)bp[NM_RHOTAB_SLOT] - 1;
    if (off < 0 || a < 0.0f) {
        for (int l = 0; l < NM_RHO_N; ++l) rho[l] = bp[NM_RHO_SLOT + l];
        return;
    }
    float4 h = d[off];
    int ne = (int)h.z;
    float x = clamp((log(fmax(a, 1e-12f)) - h.x) / h.y, 0.0f, (float)(ne - 1));
    int i = min((int)x, ne - 2);
    float t = x - (float)i;
    __global const float *e0 = (__global const float *)(d + off + 1 + i * NM_RHO_F4);
    for (int l = 0; l < NM_RHO_N; ++l)
        rho[l] = (1.0f - t) * e0[l] + t * e0[4 * NM_RHO_F4 + l];
}

/* Eq 12: Σ_{l ≤ lmax} ρ̂_l Σ_m γ_lm Y_lm(ω) with the basis values y. */
inline float nm_sh_dot(const float *g, const float *y, const float *rho, int lmax) {
    float acc = 0.0f;
    for (int l = 0; l <= lmax; ++l) {
        float b = 0.0f;
        for (int k = l * l; k < (l + 1) * (l + 1); ++k) b += g[k] * y[k];
        acc += rho[l] * b;
    }
    return acc;
}

/* Bands 1 and 2 of tangent-frame SH coefficients g (k < 9) rotated to world coordinates
 * (frame t, b, n): band 1 is a vector, band 2 a traceless quadratic form Q with
 * f(ω) = ωᵀQω, rotated as M Q Mᵀ (M = [t b n]); band 0 is invariant. */
inline void nm_sh_rotate9(const float *g, float3 t, float3 b, float3 n, float *w) {
    const float c1 = 1.09254843059208f, c0 = 0.315391565252520f;   /* √(15/4π), √(5/16π) */
    w[0] = g[0];
    float3 v = g[3] * t + g[1] * b + g[2] * n;                        /* (Y_11, Y_1−1, Y_10) */
    w[1] = v.y; w[2] = v.z; w[3] = v.x;
    float qxy = 0.5f * c1 * g[4], qyz = 0.5f * c1 * g[5], qxz = 0.5f * c1 * g[7];
    float qxx = 0.5f * c1 * g[8] - c0 * g[6], qyy = -0.5f * c1 * g[8] - c0 * g[6];
    float qzz = 2.0f * c0 * g[6];
    /* columns of Q·Mᵀ rows: R = M Q Mᵀ, M's columns t, b, n */
    float3 r0 = qxx * t + qxy * b + qxz * n;     /* M (Q e_x) */
    float3 r1 = qxy * t + qyy * b + qyz * n;
    float3 r2 = qxz * t + qyz * b + qzz * n;
    /* R_ij = Σ_k M_ik (Q Mᵀ)_kj = t_i r0_j + b_i r1_j + n_i r2_j */
    float3 Rx = t.x * r0 + b.x * r1 + n.x * r2;
    float3 Ry = t.y * r0 + b.y * r1 + n.y * r2;
    float3 Rz = t.z * r0 + b.z * r1 + n.z * r2;
    w[4] = 2.0f * Rx.y / c1;
    w[5] = 2.0f * Ry.z / c1;
    w[6] = Rz.z / (2.0f * c0);
    w[7] = 2.0f * Rx.z / c1;
    w[8] = (Rx.x - Ry.y) / c1;
}

#endif
