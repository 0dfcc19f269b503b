/* The fit stage's one BRDF form (docs/ARTIFACTS.md fit/, Wang09 eq 8–14):
 *   ρ(o, i) = f_d(o, i) + M_o(i) D(h),  M_o(i) = ks g_scale F(o·h) G2(o, i) / (π (n·i)(n·o)),
 * everything in the local frame (z = n, x = t, y = b). Materials are float records of
 * MAT_STRIDE values (layout: MAT_* of records.h, packed by sgpipe/render/materials.py). */
#ifndef SGPIPE_MICROFACET_H
#define SGPIPE_MICROFACET_H

#include "records.h"   /* MAT_STRIDE, MAT_* slots (generated: sgpipe/render/records.py) */

#define MF_INV_PI 0.318309886183791f
#define MF_SQRT_PI 1.77245385090552f

inline float3 mat3(__global const float *m, int k) { return (float3)(m[k], m[k + 1], m[k + 2]); }

inline float3 fresnel_conductor(float c, float3 eta, float3 k) {
    float cos2 = c * c, sin2 = 1.0f - cos2;
    float3 eta2 = eta * eta, k2 = k * k;
    float3 t0 = eta2 - k2 - sin2;
    float3 a2b2 = sqrt(t0 * t0 + 4.0f * eta2 * k2);
    float3 t1 = a2b2 + cos2;
    float3 a = sqrt(fmax(0.5f * (a2b2 + t0), 0.0f));
    float3 t2 = 2.0f * c * a;
    float3 rs = (t1 - t2) / (t1 + t2);
    float3 t3 = cos2 * a2b2 + sin2 * sin2;
    float3 t4 = t2 * sin2;
    float3 rp = rs * (t3 - t4) / (t3 + t4);
    return 0.5f * (rp + rs);
}

inline float fresnel_dielectric1(float c, float eta) {
    float g2 = eta * eta + c * c - 1.0f;
    if (g2 < 0.0f) return 1.0f;
    float g = sqrt(g2);
    float a = (g - c) / (g + c);
    float b = (c * (g + c) - 1.0f) / (c * (g - c) + 1.0f);
    return 0.5f * a * a * (1.0f + b * b);
}

/* Schlick's F0 + (1 − F0)(1 − c)⁵, c clamped to [0, 1]. */
inline float3 fresnel_schlick(float3 f0, float c) {
    float x = 1.0f - clamp(c, 0.0f, 1.0f), x2 = x * x;
    return f0 + (1.0f - f0) * (x2 * x2 * x);
}

inline float3 mf_fresnel(__global const float *m, float c) {
    int kind = (int)m[MAT_FRESNEL];
    c = clamp(c, 0.0f, 1.0f);
    if (kind == 1) return fresnel_schlick(mat3(m, MAT_F0), c);
    if (kind == 2) return fresnel_conductor(fmax(c, 1e-4f), mat3(m, MAT_ETA), mat3(m, MAT_K));
    if (kind == 3) { float3 e = mat3(m, MAT_ETA); return (float3)(fresnel_dielectric1(c, e.x), fresnel_dielectric1(c, e.y), fresnel_dielectric1(c, e.z)); }
    return (float3)(1.0f);
}

/* a_v² tan²θ_v for the Smith kinds (anisotropic roughness along x = t, y = b). */
inline float smith_a2tan2(float3 v, float au, float av) {
    float z2 = v.z * v.z;
    float s2 = fmax(1.0f - z2, 0.0f);
    float xy2 = v.x * v.x + v.y * v.y;
    float c2 = xy2 > 0.0f ? v.x * v.x / xy2 : 1.0f;
    float a2 = au * au * c2 + av * av * (1.0f - c2);
    return a2 * s2 / fmax(z2, 1e-12f);
}

inline float g1_ggx(float3 v, float au, float av) { return 2.0f / (1.0f + sqrt(1.0f + smith_a2tan2(v, au, av))); }

inline float g1_beckmann(float3 v, float au, float av) {
    float t = smith_a2tan2(v, au, av);
    if (t <= 0.0f) return 1.0f;
    float a = 1.0f / sqrt(t);
    if (a >= 6.0f) return 1.0f;
    float lam = 0.5f * (erf(a) - 1.0f) + exp(-a * a) / (2.0f * a * MF_SQRT_PI);
    return 1.0f / (1.0f + lam);
}

/* S(θ) of a 90-bin shadow table (bin centres at 0.5° … 89.5°), linear between centres and
 * from the last centre to S(90°) = 0, where every microfacet surface's masking ends. */
inline float shadow_table(__global const float *tab, float cos_theta) {
    float th = acos(clamp(cos_theta, 0.0f, 1.0f)) * (180.0f / 3.14159265358979f) - 0.5f;
    if (th > 89.0f) return tab[89] * fmax(2.0f * (89.5f - th), 0.0f);
    th = fmax(th, 0.0f);
    int k = min((int)floor(th), 88);
    float f = th - (float)k;
    return mix(tab[k], tab[k + 1], f);
}

inline float mf_g2(__global const float *m, __global const float *tables, float3 o, float3 i, float3 h) {
    int kind = (int)m[MAT_SHADOW];
    float ni = i.z, no = o.z;
    if (kind == 1) return ni * no;
    if (kind == 2) { float nh = h.z, oh = fmax(dot(o, h), 1e-6f); return fmin(1.0f, fmin(2.0f * nh * no / oh, 2.0f * nh * ni / oh)); }
    if (kind == 3) return g1_ggx(o, m[MAT_AU], m[MAT_AV]) * g1_ggx(i, m[MAT_AU], m[MAT_AV]);
    if (kind == 4) return g1_beckmann(o, m[MAT_AU], m[MAT_AV]) * g1_beckmann(i, m[MAT_AU], m[MAT_AV]);
    if (kind == 5) return sqrt(ni * no);
    if (kind == 6) return ni * no / (fmax(dot(o, h), 1e-6f) * fmax(ni, no));
    if (kind == 7) { __global const float *t = tables + (int)m[MAT_STAB]; return shadow_table(t, ni) * shadow_table(t, no); }
    if (kind == 8) return 2.0f / (sqrt(1.0f + smith_a2tan2(o, m[MAT_AU], m[MAT_AV])) + sqrt(1.0f + smith_a2tan2(i, m[MAT_AU], m[MAT_AV])));
    return 1.0f;
}

/* M_o(i) (Wang09 eq 9/11/13) in the local frame, RGB; 0 unless n·i > 0 and n·o > 0.
 * `ks` is the (possibly textured) specular colour. */
inline float3 mf_M(__global const float *m, __global const float *tables, float3 ks, float3 o, float3 i) {
    if (i.z <= 0.0f || o.z <= 0.0f) return (float3)(0.0f);
    float3 h = normalize(o + i);
    float3 F = mf_fresnel(m, dot(o, h));
    float G = mf_g2(m, tables, o, i, h);
    return ks * (m[MAT_GSCALE] * G * MF_INV_PI / (i.z * o.z)) * F;
}

/* f_d(o, i) with a (possibly textured) diffuse colour kd; 0 below the horizon. */
inline float3 mf_diffuse(__global const float *m, float3 kd, float3 o, float3 i) {
    int kind = (int)m[MAT_DIFFUSE];
    if (kind == 2 || i.z <= 0.0f || o.z <= 0.0f) return (float3)(0.0f);
    if (kind == 1) {
        float3 f0 = mat3(m, MAT_F0);
        float a = 1.0f - 0.5f * i.z, b = 1.0f - 0.5f * o.z;
        float a5 = a * a * a * a * a, b5 = b * b * b * b * b;
        return kd * (28.0f / (23.0f * 3.14159265358979f)) * (1.0f - f0) * (1.0f - a5) * (1.0f - b5);
    }
    if (kind == 3) {   /* glTF metal-rough: the dielectric's diffuse under its F0 0.04 coat */
        float x = 1.0f - clamp(fabs(dot(o, normalize(o + i))), 0.0f, 1.0f);
        float x2 = x * x;
        return kd * MF_INV_PI * (0.96f * (1.0f - x2 * x2 * x));
    }
    return kd * MF_INV_PI;
}

/* mf_diffuse split as f_d(o, i) = colour(o) · s(i) for env_diffuse.h's lanes (same formulas):
 * the colour, 0 returned where f_d ≡ 0 (kind 2, o below the horizon) ... */
inline int mf_diffuse_colour(__global const float *m, float3 kd, float3 o, float3 *c) {
    int kind = (int)m[MAT_DIFFUSE];
    if (kind == 2 || o.z <= 0.0f) return 0;
    if (kind == 1) {
        float b = 1.0f - 0.5f * o.z, b5 = b * b * b * b * b;
        *c = kd * (28.0f / (23.0f * 3.14159265358979f)) * (1.0f - mat3(m, MAT_F0)) * (1.0f - b5);
    } else {
        *c = kd * MF_INV_PI;
    }
    return 1;
}
/* ... and s(i) for 8 directions i (0 below the horizon). */
inline float8 mf_diffuse_lane(__global const float *m, float3 o, float8 ix, float8 iy,
                              float8 iz) {
    int kind = (int)m[MAT_DIFFUSE];
    float8 s = (float8)(1.0f);
    if (kind == 1) {
        float8 a = 1.0f - 0.5f * iz;
        s = 1.0f - a * a * a * a * a;
    } else if (kind == 3) {
        float8 hx = o.x + ix, hy = o.y + iy, hz = o.z + iz;
        float8 c = fabs(o.x * hx + o.y * hy + o.z * hz) * rsqrt(hx * hx + hy * hy + hz * hz);
        float8 x = 1.0f - clamp(c, 0.0f, 1.0f), x2 = x * x;
        s = 0.96f * (1.0f - x2 * x2 * x);
    }
    return iz > 0.0f ? s : (float8)(0.0f);
}

/* Exact NDF D(h) from the material's table (materials.tabulate_ndf, ndf_info = (offset, nt, np,
 * has)): rows t = √(1 − cos θ_h) ∈ [0, 1], columns φ ∈ [0, 2π). */
inline float ndf_table(__global const float *tables, int4 info, float3 h) {
    if (h.z <= 0.0f) return 0.0f;
    int nt = info.y, np = info.z;
    float t = sqrt(clamp(1.0f - h.z, 0.0f, 1.0f)) * (float)(nt - 1);
    int t0 = min((int)floor(t), nt - 2);
    float ft = t - (float)t0;
    __global const float *tab = tables + info.x;
    if (np <= 1) return mix(tab[t0], tab[t0 + 1], ft);
    float ph = atan2(h.y, h.x);
    if (ph < 0.0f) ph += 2.0f * 3.14159265358979f;
    float pc = ph / (2.0f * 3.14159265358979f) * (float)np;
    int p0 = (int)floor(pc) % np, p1 = (p0 + 1) % np;
    float fp = pc - floor(pc);
    float a = mix(tab[t0 * np + p0], tab[t0 * np + p1], fp);
    float b = mix(tab[(t0 + 1) * np + p0], tab[(t0 + 1) * np + p1], fp);
    return mix(a, b, ft);
}

/* The exact NDF D(h) of a pixel's material: a textured gltf_pbr pixel's (MAT_SV: its own
 * GGX, peak-normalised as brdf.ndf.GGXNDF: 1/(x²/α_t² + y²/α_b² + z²)²), else the material's
 * table. */
inline float ndf_exact(__global const float *m, __global const float *tables, int4 info,
                       float3 h) {
    if (m[MAT_SV] > 0.5f) {
        if (h.z <= 0.0f) return 0.0f;
        float au = m[MAT_AU], av = m[MAT_AV];
        float q = h.x * h.x / (au * au) + h.y * h.y / (av * av) + h.z * h.z;
        return 1.0f / (q * q);
    }
    return ndf_table(tables, info, h);
}

/* SG lobe j of a pixel's material, (axis, λ) and (μ, …) as in the lobe table; a textured
 * gltf_pbr pixel's lobes interpolated between two roughness-grid entries (ln λ and μ linear
 * in ln α with weight MAT_SVFRAC on the entry MAT_SVSTEP rows on: fit.ndf_sg_rough); then
 * convolved with vMF(kc) where kc > 0 (a normal-map lobe's; 0: none). */
inline void ndf_lobe(__global const float4 *lobes, __global const float *m, int j, float kc,
                     float4 *l0, float4 *l1) {
    int l = (int)m[MAT_LOBE0] + j;
    *l0 = lobes[2 * l];
    *l1 = lobes[2 * l + 1];
    float t = m[MAT_SVFRAC];
    if (t > 0.0f) {
        int u = l + (int)m[MAT_SVSTEP];
        float4 b0 = lobes[2 * u], b1 = lobes[2 * u + 1];
        (*l0).w = exp(mix(log((*l0).w), log(b0.w), t));
        (*l1).x = mix((*l1).x, b1.x, t);
    }
    if (kc > 0.0f) {          /* a normal-map lobe's vMF: λ′ = λκ/(λ + κ), mass kept */
        float lc = (*l0).w * kc / ((*l0).w + kc);
        (*l1).x *= lc / (*l0).w;
        (*l0).w = lc;
    }
}

#endif
