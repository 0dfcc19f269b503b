/* Han07 normal-map filtering, point / directional lights (Algorithm 2, eq 20, 24): the shading
 * of the `vmf`, `normals_mip` and `toksvig` kernels, chosen by NM_FILTER before this header.
 *   lookup  trilinear in the pixel's texture footprint (isotropic level log2 of the longer UV
 *           derivative in texels, sgpipe.scene.footprint), of α_j and α_j·r_j (eq 24), then
 *           r = αr/α, κ = (3|r| − |r|³)/(1 − |r|²), μ = r/|r| (sgpipe.normalmap.vmf.lookup)
 *   vmf     Σ_j α_j · ks/4 · (s+2)/(s+1) · (s′_j+1)/(2π) (μ_j·h)^{s′_j} · (μ_j·i), s′ = κs/(κ+s)
 *           (eq 20 applied to the normalised Blinn–Phong ρ_s = ks (s+2)/(8π)(n·h)^s; the
 *           cosine and the view lift taken at the lobe axis), diffuse kd/π · max(0, n̄·i) with
 *           n̄ the plain MIP of the normals (linear in the NDF: exact while no normal faces away)
 *   normals_mip / toksvig  the same BRDF at n̄/|n̄|, exponent s or Toksvig's f·s,
 *           f = |n̄|/(|n̄| + s(1 − |n̄|)).
 * Lights are delta lights of the records' intensity (as the reference's default); no shadows
 * and no environment term in this step. Layout of nm_*: sgpipe/render/normalmap_data.py. */
#ifndef SGPIPE_NM_SHADE_H
#define SGPIPE_NM_SHADE_H

#define NM_VMF 0
#define NM_MIP 1
#define NM_TOKSVIG 2
#define NM_INV_2PI 0.159154943091895f

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
    float4 v = mean ? nm_bilinear(d, a.z, a.y, 1, 0, uv) : nm_bilinear(d, a.x, a.y, stride, slot, uv);
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

__kernel void NM_KERNEL(NM_ARGS)
{
    int gid = get_global_id(0);
    if (gid >= n) return;
    Pixel px = pixel_init(gid, gnrm, gtan, gview, gpos, guv, gobj, objs, mats, texels, texinfo);
    float3 N = px.N, T = px.T, B = px.B, x = px.x;
    int obj = gobj[gid];
    int4 info = nm_info[obj];
    float s = nm_brdf[4 * obj];
    float3 o = normalize(to_world(lift(to_local(gview[gid].xyz, T, B, N), 0.01f), T, B, N));

    /* MIP level from the footprint (clamped to the pyramid), trilinear weights */
    int l0 = 0, l1 = 0;
    float f = 0.0f;
    if (info.w) {
        float4 duv = gduv[gid];
        float len = fmax(length(duv.xy), length(duv.zw)) * (float)nm_levels[info.x].y;
        float lod = clamp(log2(fmax(len, 1e-18f)), 0.0f, (float)(info.y - 1));
        l0 = (int)floor(lod);
        l1 = min(l0 + 1, info.y - 1);
        f = lod - (float)l0;
        l0 += info.x; l1 += info.x;
    }
    float3 mean_t = info.w ? nm_trilinear(nm_data, nm_levels, l0, l1, f, 0, 0, 1, px.uv).xyz
                           : (float3)(0.0f, 0.0f, 1.0f);
    float3 mean = to_world(mean_t, T, B, N);
    float rl = length(mean);
    float3 nbar = rl > 0.0f ? mean / rl : N;

    float3 acc = (float3)(0.0f);
    for (int k = 0; k < n_lights; ++k) {
        float4 a = lights[2 * k], b = lights[2 * k + 1];
        float3 i, E;
        if (a.w < 0.5f) {
            float3 d = a.xyz - x;
            float d2 = fmax(dot(d, d), 1e-12f);
            i = d * rsqrt(d2);
            E = b.xyz / d2;
        } else {
            i = normalize(a.xyz);
            E = b.xyz;
        }
        if (dot(i, N) <= 0.0f) continue;
        float spec = 0.0f, diff;
#if NM_FILTER == NM_VMF
        diff = fmax(dot(mean, i), 0.0f);
        if (!info.w) {
            spec = nm_blinn(N, o, i, s, (s + 2.0f) * 0.125f * MF_INV_PI);
        } else {
            for (int j = 0; j < info.z; ++j) {
                float4 t = nm_trilinear(nm_data, nm_levels, l0, l1, f, info.z, j, 0, px.uv);
                if (t.x <= 0.0f) continue;
                float3 r = t.yzw / t.x;
                float lr = length(r);
                if (lr <= 0.0f) continue;
                float kappa = lr >= 1.0f ? 1e30f : (3.0f * lr - lr * lr * lr) / (1.0f - lr * lr);
                float sp = kappa * s / (kappa + s);                         /* eq 20 */
                float3 mu = normalize(to_world(r / lr, T, B, N));
                float norm = 0.25f * (s + 2.0f) / (s + 1.0f) * (sp + 1.0f) * NM_INV_2PI;
                spec += t.x * nm_blinn(mu, o, i, sp, norm);
            }
        }
#else
        float e = s;
#if NM_FILTER == NM_TOKSVIG
        if (info.w) e = s * rl / (rl + s * (1.0f - rl));
#endif
        diff = fmax(dot(nbar, i), 0.0f);
        spec = nm_blinn(nbar, o, i, e, (e + 2.0f) * 0.125f * MF_INV_PI);
#endif
        acc += (px.kd * (diff * MF_INV_PI) + px.ks * spec) * E;
    }
    out[gid] = (float4)(acc, 1.0f);
}

#endif
