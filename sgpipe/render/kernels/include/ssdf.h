/* SSDF visibility (Wang09 §5): concentric-square hemisphere map, PCA decode (eq 24) and the
 * SG × visibility integral f_h (eq 30–31, appendix eq 46–49).
 *
 * PCA basis storage: float basis[res][res][NV] (texel-major, so one bilinear tap reads NV
 * consecutive floats) and float mean[res][res]; texel (row i, column j) has its centre at the
 * concentric-square point u = (j + 0.5)/res, v = (i + 0.5)/res (core.sphere convention).
 * Requires NV (number of PCA terms, may be 0) and FH_A, FH_C3..FH_C0 (sigmoid coefficients). */
#ifndef SGPIPE_SSDF_H
#define SGPIPE_SSDF_H

#define SSDF_PI_4 0.785398163397448f
#define SSDF_PI_2 1.5707963267949f

/* atan t for |t| ≤ 1 (Cephes atanf: one reduction at tan π/8, then a degree-9 odd polynomial;
 * relative error ≤ 2e-7): the library atan2 costs ~65 cycles a call on the CPU device, and
 * the SSDF decodes a dozen directions per pixel. */
#define SSDF_ATAN_POLY(x, z) \
    ((((8.05374449538e-2f * (z) - 1.38776856032e-1f) * (z) + 1.99777106478e-1f) * (z) \
      - 3.33329491539e-1f) * (z) * (x) + (x))

inline float ssdf_atan_unit(float t) {
    float at = fabs(t);
    int big = at > 0.41421356f;
    float x = big ? (at - 1.0f) / (at + 1.0f) : at;
    float z = x * x;
    return copysign(SSDF_ATAN_POLY(x, z) + (big ? SSDF_PI_4 : 0.0f), t);
}

/* Shirley–Chiu disk → square, the inverse of core.sphere._square_to_disk: on the major axis's
 * side (|x| ≥ |y|: a = s, b = s φ/(π/4), φ = atan(y/x); else b = s, a = s(π/2 − φ)/(π/4),
 * π/2 − φ = atan(x/y)), s = ±r with the major coordinate's sign. */
inline float2 disk_to_square(float x, float y) {
    float r = sqrt(x * x + y * y);
    int major_x = fabs(x) >= fabs(y);
    float num = major_x ? y : x, den = major_x ? x : y;
    float s = den >= 0.0f ? r : -r;
    float pa = s * ssdf_atan_unit(den != 0.0f ? num / den : 0.0f) * (1.0f / SSDF_PI_4);
    float a = major_x ? s : pa, b = major_x ? pa : s;
    return (float2)(0.5f * (a + 1.0f), 0.5f * (b + 1.0f));
}

/* Local direction (z = normal, z >= 0) → concentric square (u, v): inverse of the
 * area-preserving map z = 1 − r² (core.sphere.hemisphere_to_concentric_square). */
inline float2 hemisphere_to_square(float3 d) {
    float z = clamp(d.z, 0.0f, 1.0f);
    float rho = sqrt(d.x * d.x + d.y * d.y);
    /* r/ρ with r = √(1 − z); near the pole as 1/√(1 + z) (1 − z = ρ²/(1 + z) for unit d):
     * 1 − z in float32 keeps few digits there, and the map's r amplifies them (√ of an ulp) */
    float sc = rho > 0.0f ? (z > 0.5f ? rsqrt(1.0f + z) : sqrt(1.0f - z) / rho) : 0.0f;
    return disk_to_square(d.x * sc, d.y * sc);
}

/* The PCA terms are read and summed in vectors of SSDF_VW floats, the widest of 16, 8, 4 that
 * divides NV (NV is a multiple of 4, zero-padded terms): a 48-term decode is then 3 AVX-512
 * multiply-adds per tap instead of 12 SSE ones; `ssdf_vec` is a pixel's coefficient vector
 * chunk (shading.h Vis). */
#if NV > 0 && NV % 16 == 0
#define SSDF_VW 16
typedef float16 ssdf_vec;
#define ssdf_vload vload16
inline float ssdf_hsum(float16 a) {
    float8 b = a.lo + a.hi;
    float4 c = b.lo + b.hi;
    return c.x + c.y + c.z + c.w;
}
#elif NV > 0 && NV % 8 == 0
#define SSDF_VW 8
typedef float8 ssdf_vec;
#define ssdf_vload vload8
inline float ssdf_hsum(float8 a) { float4 c = a.lo + a.hi; return c.x + c.y + c.z + c.w; }
#else
#define SSDF_VW 4
typedef float4 ssdf_vec;
#define ssdf_vload vload4
inline float ssdf_hsum(float4 c) { return c.x + c.y + c.z + c.w; }
#endif
#define SSDF_NW (NV > 0 ? NV / SSDF_VW : 1)

#if NV > 0
/* Bilinear reconstruction of Σ_j 𝕍_j(u, v) w_j + mean(u, v) (Wang09 eq 24), edge-clamped:
 * one tap reads NV consecutive floats as NV/SSDF_VW vectors. */
inline float ssdf_decode_square(__global const float *basis, __global const float *mean, int res,
                                const ssdf_vec *w, float2 uv) {
    float x = uv.x * (float)res - 0.5f, y = uv.y * (float)res - 0.5f;
    float x0f = floor(x), y0f = floor(y);
    float fx = x - x0f, fy = y - y0f;
    int x0 = clamp((int)x0f, 0, res - 1), x1 = clamp((int)x0f + 1, 0, res - 1);
    int y0 = clamp((int)y0f, 0, res - 1), y1 = clamp((int)y0f + 1, 0, res - 1);
    int t00 = y0 * res + x0, t10 = y0 * res + x1, t01 = y1 * res + x0, t11 = y1 * res + x1;
    float w00 = (1.0f - fx) * (1.0f - fy), w10 = fx * (1.0f - fy), w01 = (1.0f - fx) * fy;
    float w11 = fx * fy;
    __global const float *b00 = basis + t00 * NV, *b10 = basis + t10 * NV;
    __global const float *b01 = basis + t01 * NV, *b11 = basis + t11 * NV;
    ssdf_vec acc = (ssdf_vec)(0.0f);
    for (int j = 0; j < SSDF_NW; ++j)
        acc += w[j] * (w00 * ssdf_vload(j, b00) + w10 * ssdf_vload(j, b10)
                       + w01 * ssdf_vload(j, b01) + w11 * ssdf_vload(j, b11));
    float m = w00 * mean[t00] + w10 * mean[t10] + w01 * mean[t01] + w11 * mean[t11];
    return m + ssdf_hsum(acc);
}
#endif

/* Signed angular distance θ_d at local direction d (eq 23). Without data (has_ssdf = 0) the
 * surface's own tangent plane is the only occluder: θ_d = asin(d.z). Below the horizon
 * (β = −asin d.z) the nearest boundary is at least β away: θ_d ≈ min(θ_d(horizon), 0) − β. */
inline float ssdf_theta(int has_ssdf, __global const float *basis, __global const float *mean,
                        int res, const ssdf_vec *w, float3 d) {
    float z = clamp(d.z, -1.0f, 1.0f);
#if NV > 0
    if (has_ssdf) {
        if (z >= 0.0f) return ssdf_decode_square(basis, mean, res, w, hemisphere_to_square(d));
        if (dot(d.xy, d.xy) < 1e-20f) return asin(z);   /* ℓ = −n: S_h := 0 (visibility/decode.py) */
        float th = ssdf_decode_square(basis, mean, res, w,
                                      hemisphere_to_square(normalize((float3)(d.x, d.y, 0.0f))));
        return fmin(th, 0.0f) + asin(z);
    }
#endif
    return asin(z);
}

#ifdef FH_TABLE
/* f̂_h(θ_d, λ) (eq 46) of the hemisphere visibility model, tabulated from the exact integral
 * (core.fh.fh_hat_exact) on θ_d ∈ [−π/2, π/2] × ln λ ∈ [FH_TAB_L0, FH_TAB_L1], bilinear; sharper
 * lobes use the planar limit Φ(θ_d √λ) (|error| < 4e-4 from λ = 300 on). The table header is
 * generated by sgpipe/render/headers.py (fh_table_header). */
#include "fh_table.h"
/* (f̂_h, λ·f_h) where f_h = min(f̂_h f_h(π/2, λ), ∫G) (both smooth and bounded in ln λ). */
inline float2 fh_pair_scaled(float theta_d, float lam) {
    if (lam >= FH_TAB_LAMMAX) {
        float p = half_erfc(-theta_d * sqrt(lam) * 0.70710678f);
        return (float2)(p, 6.28318531f * p);
    }
    float x = (log(fmax(lam, FH_TAB_LAMMIN)) - FH_TAB_L0) / (FH_TAB_L1 - FH_TAB_L0) * (float)(FH_TAB_NL - 1);
    float y = (clamp(theta_d, -1.5707963f, 1.5707963f) + 1.5707963f) / 3.14159265f * (float)(FH_TAB_NT - 1);
    int x0 = clamp((int)floor(x), 0, FH_TAB_NL - 2), y0 = clamp((int)floor(y), 0, FH_TAB_NT - 2);
    float fx = clamp(x - (float)x0, 0.0f, 1.0f), fy = clamp(y - (float)y0, 0.0f, 1.0f);
    __constant const float2 *r0 = (__constant const float2 *)FH_TAB + x0 * FH_TAB_NT + y0;
    __constant const float2 *r1 = r0 + FH_TAB_NT;
    return mix(mix(r0[0], r0[1], fy), mix(r1[0], r1[1], fy), fx);
}
inline float fh_hat(float theta_d, float lam) { return fh_pair_scaled(theta_d, lam).x; }
/* Wang09 eq 30 (capped at the lobe's full integral): G · V ≈ μ f_h(θ_d, λ). */
inline float3 sg_dot_visibility(SG g, float theta_d) {
    float lam = fmax(g.lam, FH_TAB_LAMMIN);
    return g.mu * (fh_pair_scaled(theta_d, lam).y / lam);
}
#else
/* Wang09 appendix eq 47–48 (read as a rising sigmoid, see core/fh.py):
 * σ(θ_d; k) = a / (1 + e^{−k θ_d}) + (1 − a)/2, k = c3 λ³ + c2 λ² + c1 λ + c0, divided by
 * σ(π/2; k) so that f̂_h(π/2, λ) = 1 exactly as eq 46 defines it (an unoccluded lobe keeps its
 * hemisphere integral; the raw fit is a few % off there for broad lobes). */
inline float fh_sigma(float theta_d, float k) {
    float e = exp(-clamp(k * theta_d, -80.0f, 80.0f));
    return FH_A / (1.0f + e) + 0.5f * (1.0f - FH_A);
}
inline float fh_hat(float theta_d, float lam) {
    float k = ((FH_C3 * lam + FH_C2) * lam + FH_C1) * lam + FH_C0;
#ifdef W09_FH_RAW
    return fmax(fh_sigma(theta_d, k), 0.0f);          /* eq 49 as printed: not renormalised */
#else
    return fmax(fh_sigma(theta_d, k) / fh_sigma(1.5707963f, k), 0.0f);
#endif
}
#endif

/* f_h(π/2, λ) = 2π(1 − e^{−λ})/λ: the lobe integrated over the hemisphere around its axis. */
inline float fh_hemi(float lam) { return lam < 1e-4f ? SG_TWO_PI : -SG_TWO_PI * expm1(-lam) / lam; }

#ifndef FH_TABLE
/* Wang09 eq 30: G · V ≈ μ f_h(θ_d, λ) = μ f̂_h(θ_d, λ) f_h(π/2, λ). */
inline float3 sg_dot_visibility(SG g, float theta_d) {
#ifdef W09_FH_RAW
    return g.mu * (fh_hat(theta_d, g.lam) * fh_hemi(g.lam));
#else
    return g.mu * fmin(fh_hat(theta_d, g.lam) * fh_hemi(g.lam), sg_integral_unit(g.lam));
#endif
}
#endif

/* Wang09 eq 31: G ⊗ V ≈ G(i; p, λ, f̂_h(θ_d, λ) μ). */
inline SG sg_times_visibility(SG g, float theta_d) { g.mu *= fh_hat(theta_d, g.lam); return g; }

#endif
