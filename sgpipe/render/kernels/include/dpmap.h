/* Dual-paraboloid MIP chains (Töral19 eq 9–11) in the envmap stage's "dp2h" layout
 * (docs/ARTIFACTS.md, envmap/mip/dp_MM.exr): a level of resolution n is an n × 2n image, the
 * front paraboloid (z ≥ 0) in columns [0, n), the back one in [n, 2n); texel (row i, col j) of a
 * hemisphere sits at s = (j + 0.5)/n, t = (i + 0.5)/n with ρ = b (2s − 1, 1 − 2t) and
 * direction (±2ρx, 2ρy, ±(1 − ρ²))/(1 + ρ²) (sgpipe.core.maps.dual_paraboloid_dir; the back map
 * mirrors x and z). A direction reads the hemisphere of its z sign, clamped to that square's
 * edge (sgpipe.envmap.maps.sample_dual_paraboloid): with b > 1 the square holds directions past
 * the equator, so no lookup has to cross to the other map. All levels are packed in one float4
 * buffer, level l from texel off[l]; directions go through env_to_map (cubemap.h). */
#ifndef SGPIPE_DPMAP_H
#define SGPIPE_DPMAP_H
#include "cubemap.h"

/* World d → hemisphere (0 front, 1 back) and s, t ∈ [0, 1] of its paraboloid of scale b. */
inline int dp_coords(float3 d, float b, float *s, float *t) {
    d = env_to_map(d);
    int hemi = d.z >= 0.0f ? 0 : 1;
    float inv = 1.0f / (1.0f + fabs(d.z));
    float px = (hemi ? -d.x : d.x) * inv, py = d.y * inv;
    *s = 0.5f * (px / b + 1.0f);
    *t = 0.5f * (1.0f - py / b);
    return hemi;
}

/* Bilinear fetch of a level (resolution n, from texel off) at (hemi, s, t), clamp-to-edge. */
inline float3 dp_bilinear_st(__global const float4 *data, int off, int n, int hemi, float s,
                             float t) {
    float u = s * (float)n - 0.5f, v = t * (float)n - 0.5f;
    float fu0 = floor(u), fv0 = floor(v);
    float fu = u - fu0, fv = v - fv0;
    int j0 = clamp((int)fu0, 0, n - 1), j1 = clamp((int)fu0 + 1, 0, n - 1);
    int i0 = clamp((int)fv0, 0, n - 1), i1 = clamp((int)fv0 + 1, 0, n - 1);
    int w = 2 * n, c = off + hemi * n;
    float3 a = mix(data[c + i0 * w + j0].xyz, data[c + i0 * w + j1].xyz, fu);
    float3 e = mix(data[c + i1 * w + j0].xyz, data[c + i1 * w + j1].xyz, fu);
    return mix(a, e, fv);
}

inline float3 dp_bilinear(__global const float4 *data, int off, int n, float b, float3 d) {
    float s, t;
    int hemi = dp_coords(d, b, &s, &t);
    return dp_bilinear_st(data, off, n, hemi, s, t);
}

/* Trilinear: bilinear in the levels around `lod` (clamped to [0, nlev − 1]), linear between. */
inline float3 dp_mip(__global const float4 *data, __global const int *off,
                     __global const int *res, int nlev, float b, float3 d, float lod) {
    lod = clamp(lod, 0.0f, (float)(nlev - 1));
    int l0 = (int)floor(lod), l1 = min(l0 + 1, nlev - 1);
    float f = lod - (float)l0;
    float s, t;
    int hemi = dp_coords(d, b, &s, &t);
    float3 a = dp_bilinear_st(data, off[l0], res[l0], hemi, s, t);
    if (f <= 0.0f || l1 == l0) return a;
    return mix(a, dp_bilinear_st(data, off[l1], res[l1], hemi, s, t), f);
}

/* Töral19 eq 9 + 11: Ω_p = d(i)/(w·h), d(i) = 4b²(|i_z| + 1)², w = h = N (the finest level). */
inline float dp_texel_solid_angle(float3 d, int N, float b) {
    d = env_to_map(d);
    float z1 = fabs(d.z) + 1.0f;
    return 4.0f * b * b * z1 * z1 / ((float)N * (float)N);
}

/* Töral19 eq 8 + 10: lod = ½ log2(Ω_s/Ω_p), Ω_s = −2π ln(1 − a)/κ. */
inline float dp_lobe_lod(float3 d, float kappa, float a, int N, float b) {
    float omega_s = -SG_TWO_PI * log(1.0f - a) / fmax(kappa, 1e-6f);
    return 0.5f * log2(omega_s / dp_texel_solid_angle(d, N, b));
}

#endif
