/* Han07 normal-map filtering, point / directional lights (Algorithm 2, eq 20, 24): helpers of
 * the `vmf`, `normals_mip` and `toksvig` kernels; their common body is nm_shade_body.h,
 * included inside each kernel, the filter chosen by NM_FILTER.
 *   lookup  trilinear in the pixel's texture footprint (isotropic level log2 of the longer UV
 *           derivative in texels, sgpipe.scene.footprint), of α_j and α_j·r_j (eq 24), then
 *           r = αr/α, κ = (3|r| − |r|³)/(1 − |r|²), μ = r/|r| (sgpipe.normalmap.vmf.lookup)
 *   vmf     Σ_j α_j · ks/4 · (s+2)/(s+1) · (s′_j+1)/(2π) (μ_j·h)^{s′_j} · (μ_j·i), s′ = κs/(κ+s)
 *           (eq 20 applied to the normalised Blinn–Phong ρ_s = ks (s+2)/(8π)(n·h)^s; the
 *           cosine and the view lift taken at the lobe axis), diffuse kd/π · max(0, n̄·i) with
 *           n̄ the plain MIP of the normals (linear in the NDF: exact while no normal faces away)
 *   normals_mip / toksvig  the same BRDF at n̄/|n̄|, exponent s or Toksvig's f·s,
 *           f = |n̄|/(|n̄| + s(1 − |n̄|)).
 * Lights are delta lights of the records' intensity (as the reference's default), unshadowed.
 * Environment: only its diffuse part, the sg method's SG-light sum (diffuse_env_sg, with the
 * SSDF visibility) about n̄/|n̄|; no environment specular in this step.
 * Layout of nm_*: sgpipe/render/normalmap_data.py. */
#ifndef SGPIPE_NM_SHADE_H
#define SGPIPE_NM_SHADE_H

#define NM_VMF 0
#define NM_MIP 1
#define NM_TOKSVIG 2
#define NM_INV_2PI 0.159154943091895f
#define NM_MAX_LOBES 8      /* normalmap.lobes ≤ 8 */
#define NM_MAX_L0 16        /* level-0 normals kept apart (more taps: summed modulo 16) */

/* Bilinear fetch of slot `slot` (of `stride` per texel) of a level at (off, side m): repeat
 * addressing, row 0 = v = 1, texel centres at half-integers (vmf.bilinear, tex_bilinear). */
inline float4 nm_bilinear(__global const float4 *d, int off, int m, int stride, int slot,
                          float2 uv) {
    float x = (uv.x - floor(uv.x)) * (float)m - 0.5f;
    float y = (1.0f - (uv.y - floor(uv.y))) * (float)m - 0.5f;
    float x0f = floor(x), y0f = floor(y);
    float fx = x - x0f, fy = y - y0f;
    int x0 = ((int)x0f % m + m) % m, y0 = ((int)y0f % m + m) % m;
    int x1 = (x0 + 1) % m, y1 = (y0 + 1) % m;
    __global const float4 *t = d + off + slot;
    float4 a = t[(y0 * m + x0) * stride] * (1.0f - fx) + t[(y0 * m + x1) * stride] * fx;
    float4 b = t[(y1 * m + x0) * stride] * (1.0f - fx) + t[(y1 * m + x1) * stride] * fx;
    return a * (1.0f - fy) + b * fy;
}

/* Trilinear fetch between levels l0 and l0 + 1 with weight f (f = 0: l0 only). `mean`: the
 * mean-normal slot (stride 1 at the level's mean offset) instead of lobe `slot`. */
inline float4 nm_trilinear(__global const float4 *d, __global const int4 *lev, int l0, int l1,
                           float f, int stride, int slot, int mean, float2 uv) {
    int4 a = lev[l0];
    float4 v = mean ? nm_bilinear(d, a.z, a.y, 1, 0, uv)
                    : nm_bilinear(d, a.x, a.y, stride, slot, uv);
    if (f > 0.0f) {
        int4 b = lev[l1];
        float4 w = mean ? nm_bilinear(d, b.z, b.y, 1, 0, uv)
                        : nm_bilinear(d, b.x, b.y, stride, slot, uv);
        v = v * (1.0f - f) + w * f;
    }
    return v;
}

/* Raise a unit direction to elevation ≥ asin(zmin) about the unit axis n (shading.h's lift in
 * the frame of n; the reference's mapped_view). */
inline float3 nm_lift(float3 d, float3 n, float zmin) {
    float c = dot(d, n);
    if (c >= zmin) return d;
    float3 p = d - c * n;
    float l = length(p);
    p = l > 1e-8f ? p / l : (float3)(0.0f);
    return p * sqrt(1.0f - zmin * zmin) + zmin * n;
}

/* Normalised Blinn–Phong ρ_s (n·h)-lobe times the cosine, for exponent e about axis n:
 * (e+2)/(8π)·(n·h)^e·(n·i) (ks excluded). `norm`: the lobe's normalisation factor. */
inline float nm_blinn(float3 n, float3 o, float3 i, float e, float norm) {
    float ci = dot(n, i);
    if (ci <= 0.0f) return 0.0f;
    float3 h = normalize(nm_lift(o, n, 0.01f) + i);
    return norm * pow(fmax(dot(n, h), 0.0f), e) * ci;
}

#endif
