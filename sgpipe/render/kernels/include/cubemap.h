/* Cubemaps in the envmap stage's bordered layout "cube6v_b1" (docs/ARTIFACTS.md, envmap/):
 * a level of face resolution n is a (6·(n+2)) × (n+2) image; face f (OpenGL order +X, −X, +Y,
 * −Y, +Z, −Z) occupies rows [f(n+2), (f+1)(n+2)); texel (row i, col j) sits at s = (j − 0.5)/n,
 * t = (i − 0.5)/n. The 1-texel border already holds the neighbouring/extended values, so a
 * plain per-face bilinear fetch is seamless. All levels of a chain are packed in one float4
 * buffer; level l starts at texel off[l].
 * Also: Γ_L pyramid lookups (Wang09 eq 34–35) and box-MIP lookups (Töral19 eq 6–11). */
#ifndef SGPIPE_CUBEMAP_H
#define SGPIPE_CUBEMAP_H

/* Environment rotation (render.environment_rotation): the world sees the map turned by R, so a
 * world direction d reads the map at M·d, M = Rᵀ, given row by row as the compile-time defines
 * ENV_M00 … ENV_M22 with ENV_ROT (sgpipe.render.envdata.EnvData.rotation_defines); without
 * ENV_ROT the identity. Applied in the two helpers that turn a direction into a place on the
 * cube, cube_coords and cube_texel_solid_angle, so every environment lookup below (bilinear,
 * MIP, Γ_L, raw map) and the kernels' own face fetches (cube_coords + cube_bilinear_st) follow
 * it; the direction arrays beside the maps (point set, SG light lobes) are rotated on the host.
 * Only the environment's cubemaps go through these helpers. */
inline float3 env_to_map(float3 d) {
#ifdef ENV_ROT
    return (float3)(ENV_M00 * d.x + ENV_M01 * d.y + ENV_M02 * d.z,
                    ENV_M10 * d.x + ENV_M11 * d.y + ENV_M12 * d.z,
                    ENV_M20 * d.x + ENV_M21 * d.y + ENV_M22 * d.z);
#else
    return d;
#endif
}

/* OpenGL major-axis selection (ties x > y > z) of the map direction of world d → face,
 * s, t ∈ [0, 1]. */
inline int cube_coords(float3 d, float *s, float *t) {
    d = env_to_map(d);
    float ax = fabs(d.x), ay = fabs(d.y), az = fabs(d.z);
    float sc, tc, ma;
    int face;
    if (ax >= ay && ax >= az) {
        ma = ax; face = d.x >= 0.0f ? 0 : 1;
        sc = d.x >= 0.0f ? -d.z : d.z; tc = -d.y;
    } else if (ay >= az) {
        ma = ay; face = d.y >= 0.0f ? 2 : 3;
        sc = d.x; tc = d.y >= 0.0f ? d.z : -d.z;
    } else {
        ma = az; face = d.z >= 0.0f ? 4 : 5;
        sc = d.z >= 0.0f ? d.x : -d.x; tc = -d.y;
    }
    *s = 0.5f * (sc / ma + 1.0f);
    *t = 0.5f * (tc / ma + 1.0f);
    return face;
}

/* Bilinear lookup of one bordered level (face resolution n) at face coordinates (face, s, t). */
inline float3 cube_bilinear_st(__global const float4 *data, int off, int n, int face, float s,
                               float t) {
    int w = n + 2;
    float u = clamp(s * (float)n + 0.5f, 0.5f, (float)n + 0.5f);
    float v = clamp(t * (float)n + 0.5f, 0.5f, (float)n + 0.5f);
    float j0f = floor(u), i0f = floor(v);
    float fx = u - j0f, fy = v - i0f;
    int j0 = min((int)j0f, n), i0 = min((int)i0f, n);
    __global const float4 *row0 = data + off + (face * w + i0) * w + j0;
    __global const float4 *row1 = row0 + w;
    float4 c = mix(mix(row0[0], row0[1], fx), mix(row1[0], row1[1], fx), fy);
    return c.xyz;
}

/* Bilinear lookup of one bordered level (face resolution n) in direction d. */
inline float3 cube_bilinear(__global const float4 *data, int off, int n, float3 d) {
    float s, t;
    int face = cube_coords(d, &s, &t);
    return cube_bilinear_st(data, off, n, face, s, t);
}

/* Box MIP chain at fractional level `lod` (trilinear; clamped to [0, nlev − 1]). */
inline float3 cube_mip(__global const float4 *data, __global const int *off, __global const int *res,
                       int nlev, float3 d, float lod) {
    lod = clamp(lod, 0.0f, (float)(nlev - 1));
    int l0 = (int)floor(lod);
    int l1 = min(l0 + 1, nlev - 1);
    float f = lod - (float)l0;
    float3 a = cube_bilinear(data, off[l0], res[l0], d);
    if (f <= 0.0f || l1 == l0) return a;
    return mix(a, cube_bilinear(data, off[l1], res[l1], d), f);
}

/* Töral19 eq 9 with the cube distortion D(d) = 4 max(|d_x|, |d_y|, |d_z|)³ (unit d, in the
 * map's frame): solid angle of a finest-level texel (face resolution N) around world d. */
inline float cube_texel_solid_angle(float3 d, int N) {
    d = env_to_map(d);
    float ma = fmax(fabs(d.x), fmax(fabs(d.y), fabs(d.z)));
    return 4.0f * ma * ma * ma / ((float)N * (float)N);
}

/* Töral19 eq 8 + 10: MIP level of a lobe of sharpness κ holding the fraction a of its mass. */
inline float cube_lobe_lod(float3 d, float kappa, float a, int N) {
    float omega_s = -SG_TWO_PI * log(1.0f - a) / fmax(kappa, 1e-6f);
    return 0.5f * log2(omega_s / cube_texel_solid_angle(d, N));
}

/* A(λ) = coth λ − 1/λ (mean resultant length; λ/3 for small λ; from λ = 9 on coth λ is 1 in
 * float32, e^{−18} being under half an ulp of 1: no exp there). */
inline float mean_resultant(float lam) {
    if (lam < 1e-3f) return lam / 3.0f;
    if (lam >= 9.0f) return 1.0f - 1.0f / lam;
    float e = exp(-2.0f * lam);
    return (1.0f + e) / (1.0f - e) - 1.0f / lam;
}

/* Γ_L(p, λ) = S(λ) V_λ(p) (Wang09 eq 35) from the normalised pyramid: levels hold V at
 * lam[l] = lam0 / ratio^l; linear in ln λ between levels, clamped above lam0, and below the
 * broadest level V = mean + A(λ)/A(λ_{L−1}) (V_{L−1} − mean) (envmap contract). */
inline float3 gamma_lookup(__global const float4 *data, __global const int *off,
                           __global const int *res, __global const float *lam, int nlev,
                           float log_ratio, float3 mean, float3 p, float lambda) {
    float3 v;
    if (lambda >= lam[0]) {
        v = cube_bilinear(data, off[0], res[0], p);
    } else if (lambda >= lam[nlev - 1]) {
        float x = log(lam[0] / lambda) / log_ratio;
        int l = min((int)floor(x), nlev - 2);
        l = max(l, 0);
        float w = clamp(x - (float)l, 0.0f, 1.0f);
        v = mix(cube_bilinear(data, off[l], res[l], p), cube_bilinear(data, off[l + 1], res[l + 1], p), w);
    } else {
        float w = mean_resultant(lambda) / mean_resultant(lam[nlev - 1]);
        v = mean + w * (cube_bilinear(data, off[nlev - 1], res[nlev - 1], p) - mean);
    }
    return v * sg_integral_unit(lambda);
}

/* ---- Accurate Γ_L path (docs/ARTIFACTS.md, envmap/; reference sgpipe.envmap Pyramid.lookup).
 * Chain of "cube6v_b2" levels (border 2): per texel two float4, (V, 0) then (m, 0): the cubic
 * B-spline coefficients of V = Γ_L/S(λ) (coef_LL) and of m = ∂ln Γ_L/∂ln λ (slope_LL); level l
 * starts at texel pair off[l] and has face resolution res[l]. */

/* Uniform cubic B-spline weights of taps −1, 0, 1, 2 at fraction t ∈ [0, 1). */
inline float4 bspline_weights(float t) {
    float t2 = t * t, t3 = t2 * t, u = 1.0f - t;
    return (float4)(u * u * u, 3.0f * t3 - 6.0f * t2 + 4.0f, -3.0f * t3 + 3.0f * t2 + 3.0f * t + 1.0f,
                    t3) * (1.0f / 6.0f);
}

/* 16-tap B-spline of one level at face coordinates (face, s, t): V, and m when `want_m`. */
inline float3 gamma_level(__global const float4 *data, int off, int n, int face, float s, float t,
                          int want_m, float3 *m) {
    int w = n + 4;
    float u = s * (float)n + 1.5f, v = t * (float)n + 1.5f;
    float uf = floor(u), vf = floor(v);
    float4 ws = bspline_weights(u - uf), wt = bspline_weights(v - vf);
    int j0 = (int)uf - 1, i0 = (int)vf - 1;
    int4 jj = 2 * clamp((int4)(j0, j0 + 1, j0 + 2, j0 + 3), 0, w - 1);
    int4 ii = 2 * w * clamp((int4)(i0, i0 + 1, i0 + 2, i0 + 3), 0, w - 1);
    __global const float4 *base = data + 2 * (off + face * w * w);
#define GL_ROW(r) (ws.x * (r)[jj.x] + ws.y * (r)[jj.y] + ws.z * (r)[jj.z] + ws.w * (r)[jj.w])
    float4 accv = wt.x * GL_ROW(base + ii.x) + wt.y * GL_ROW(base + ii.y)
                  + wt.z * GL_ROW(base + ii.z) + wt.w * GL_ROW(base + ii.w);
    if (want_m) {
        __global const float4 *bm = base + 1;
        float4 accm = wt.x * GL_ROW(bm + ii.x) + wt.y * GL_ROW(bm + ii.y)
                      + wt.z * GL_ROW(bm + ii.z) + wt.w * GL_ROW(bm + ii.w);
        *m = accm.xyz;
    } else {
        *m = (float3)(0.0f);
    }
#undef GL_ROW
    return accv.xyz;
}

/* The λ-dependent half of an accurate Γ_L lookup (gamma_lookup_acc): which levels, where
 * between them in ln λ, and the scalars of the Hermite — ln S at both ends, their distance in
 * ln λ, S(λ). A pixel's sub-lobes of one NDF lobe share their λ (spec_warp), so the sg kernel
 * plans once per λ and looks up each direction with gamma_lookup_plan. */
typedef struct {
    int kind;       /* GL_LEVELS: levels l, l + 1; GL_BELOW: below the broadest level;
                     * GL_RAW: level 0 towards the raw map; GL_TOP: level 0 alone;
                     * GL_RAW_ONLY: the raw map */
    int l;
    float tt, lsa, lsb, du, s_lam, w, mr;
} GammaPlan;
#define GL_LEVELS 0
#define GL_BELOW 1
#define GL_RAW 2
#define GL_TOP 3
#define GL_RAW_ONLY 4

inline GammaPlan gamma_plan(__global const float *lam, int nlev, float log_ratio, int raw_n,
                            float lambda) {
    GammaPlan g;
    g.l = 0; g.tt = 0.0f; g.lsa = 0.0f; g.lsb = 0.0f; g.du = 0.0f; g.w = 0.0f; g.mr = 0.0f;
    g.s_lam = sg_integral_unit(lambda);
    if (lambda >= lam[0]) {
        /* sharper than level 0: the Hermite of ln Γ_L in ln λ continues from level 0 (V_0, m_0)
         * to the unfiltered map (pyramid/raw.exr, "cube6v_b1", face res N) at λ_r = 1.5 N²
         * (bilinear reconstruction blurs by h²/6, h = 2/N), V = V_raw beyond; no raw level
         * (raw_n = 0): V_0 */
        float lam_r = 1.5f * (float)raw_n * (float)raw_n;
        g.kind = GL_TOP;
        if (raw_n > 0 && lam_r > lam[0]) {
            g.kind = lambda >= lam_r ? GL_RAW_ONLY : GL_RAW;
            if (g.kind == GL_RAW) {
                g.tt = log(lambda / lam[0]) / log(lam_r / lam[0]);
                float x2 = 2.0f * lam_r;
                g.mr = x2 / (exp(x2) - 1.0f) - 1.0f;          /* ∂ln S/∂ln λ at λ_r */
                g.lsa = log(sg_integral_unit(lam[0]));
                g.lsb = log(sg_integral_unit(lam_r));
                g.du = log(lam_r / lam[0]);
            }
        }
        return g;
    }
    if (lambda < lam[nlev - 1]) {
        g.kind = GL_BELOW;
        g.w = mean_resultant(lambda) / mean_resultant(lam[nlev - 1]);
        return g;
    }
    g.kind = GL_LEVELS;
    float x = log(lam[0] / lambda) / log_ratio;
    g.l = clamp((int)floor(x), 0, nlev - 2);
    g.tt = x - (float)g.l;
    float la = lam[g.l], lb = lam[g.l + 1];
    g.lsa = log(sg_integral_unit(la));
    g.lsb = log(sg_integral_unit(lb));
    g.du = log(lb / la);
    return g;
}

/* Γ_L from a cubic Hermite of y = ln Γ_L = ln(S·V) in ln λ with end slopes m (per channel;
 * linear V where V ≤ 0) between the plan's ends (a at tt = 0, b at tt = 1). */
inline float3 gamma_hermite(float3 va, float3 ma, float3 vb, float3 mb, const GammaPlan *g) {
    int3 ok = isgreater(va, (float3)(0.0f)) & isgreater(vb, (float3)(0.0f));
    float3 ya = log(select((float3)(1.0f), va, ok)) + g->lsa;
    float3 yb = log(select((float3)(1.0f), vb, ok)) + g->lsb;
    float tt = g->tt, du = g->du;
    float t2 = tt * tt, t3 = t2 * tt;
    float3 y = (2.0f * t3 - 3.0f * t2 + 1.0f) * ya + ((t3 - 2.0f * t2 + tt) * du) * ma
               + (-2.0f * t3 + 3.0f * t2) * yb + ((t3 - t2) * du) * mb;
    float3 lin = mix(va, vb, tt) * g->s_lam;
    return select(lin, exp(y), ok);
}

/* Γ_L of the point set kept beside the levels (pyramid.npz point_dirs / point_energy; records
 * (c_k, 0), (E_k, 0)): Σ_k E_k e^{λ(c_k·p − 1)}, exact at every λ (docs/ARTIFACTS.md). */
inline float3 gamma_points(__global const float4 *pts, int n, float3 p, float lambda) {
    float3 acc = (float3)(0.0f);
    for (int k = 0; k < n; ++k)
    {
        float3 d = pts[2 * k].xyz - p;       /* c·p − 1 = −½|c − p|² (no cancellation) */
        acc += pts[2 * k + 1].xyz * exp(-0.5f * lambda * dot(d, d));
    }
    return acc;
}

/* Γ_L(p, λ) (Wang09 eq 35), accurate path, λ's half planned (gamma_plan): λ ≥ λ_0 → towards
 * the raw map; between levels ℓ, ℓ+1 a cubic Hermite of ln Γ_L in ln λ with slopes m (per
 * channel; linear V where V_ℓ or V_ℓ₊₁ ≤ 0); below λ_{L−1}:
 * V = mean + A(λ)/A(λ_{L−1}) (V_{L−1} − mean). */
inline float3 gamma_lookup_plan(__global const float4 *data, __global const int *off,
                                __global const int *res, int nlev, float3 mean,
                                __global const float4 *raw, int raw_n, float3 p,
                                const GammaPlan *g) {
    float s, t;
    int face = cube_coords(p, &s, &t);
    float3 ma, mb;
    if (g->kind == GL_RAW_ONLY) return cube_bilinear(raw, 0, raw_n, p) * g->s_lam;
    if (g->kind == GL_BELOW) {
        float3 vl = gamma_level(data, off[nlev - 1], res[nlev - 1], face, s, t, 0, &ma);
        return (mean + g->w * (vl - mean)) * g->s_lam;
    }
    int l = g->l;
    float3 va = gamma_level(data, off[l], res[l], face, s, t, 1, &ma);
    if (g->kind == GL_TOP) return va * g->s_lam;
    if (g->kind == GL_RAW)
        return gamma_hermite(va, ma, cube_bilinear(raw, 0, raw_n, p), (float3)(g->mr), g);
    float3 vb = gamma_level(data, off[l + 1], res[l + 1], face, s, t, 1, &mb);
    return gamma_hermite(va, ma, vb, mb, g);
}

inline float3 gamma_lookup_acc(__global const float4 *data, __global const int *off,
                               __global const int *res, __global const float *lam, int nlev,
                               float log_ratio, float3 mean, __global const float4 *raw,
                               int raw_n, float3 p, float lambda) {
    GammaPlan g = gamma_plan(lam, nlev, log_ratio, raw_n, lambda);
    return gamma_lookup_plan(data, off, res, nlev, mean, raw, raw_n, p, &g);
}

#endif
