/* Method `fis`: filtered importance sampling (Colbert & Křivánek 2007, Töral19's baseline).
 * The specular lobe takes N samples from a fixed Hammersley set: 3N/4 drawn from the NDF's SG
 * lobes read as vMFs (h-space, i = ψ(h), pdf_i = pdf_h / (4|o·h|)), N/4 cosine-weighted
 * (defensive, for the NDF's tails), combined by the multi-sample balance heuristic:
 *   L_s = Σ_s M_o(i_s) D(h_s) L_lod(i_s) (n·i_s) V(i_s) / (N_v p_v(i_s) + N_c p_c(i_s)),
 * with the exact BRDF factors (D from the tabulated exact NDF) and L_lod the box MIP chain at
 * lod = max(½ log2(Ω_s/Ω_p) + 1, 0), Ω_s = 1/(N_v p_v + N_c p_c) (C&K's bias +1). The diffuse
 * term uses the irradiance form as C&K do (here the SG light fit with SSDF visibility, Wang09
 * eq 39). Local lights: exact ρ (n·l) E V(l). V: the SSDF sign
 * (visible iff θ_d > 0) when shadows are on. Defines: NV, FH_*, MAX_NDF_LOBES. */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"

inline float radical_inverse2(uint i) {
    i = (i << 16) | (i >> 16);
    i = ((i & 0x55555555u) << 1) | ((i & 0xAAAAAAAAu) >> 1);
    i = ((i & 0x33333333u) << 2) | ((i & 0xCCCCCCCCu) >> 2);
    i = ((i & 0x0F0F0F0Fu) << 4) | ((i & 0xF0F0F0F0u) >> 4);
    i = ((i & 0x00FF00FFu) << 8) | ((i & 0xFF00FF00u) >> 8);
    return (float)i * 2.3283064365386963e-10f;
}

inline uint hash_u32(uint x) {
    x ^= x >> 16; x *= 0x7feb352du; x ^= x >> 15; x *= 0x846ca68bu; x ^= x >> 16;
    return x;
}

/* vMF sample around `a` with concentration κ (Jakob 2012's stable inversion). */
inline float3 vmf_sample(float3 a, float kappa, float u1, float u2) {
    float w = 1.0f + log(u1 + (1.0f - u1) * exp(-2.0f * kappa)) / kappa;
    w = clamp(w, -1.0f, 1.0f);
    float r = sqrt(fmax(0.0f, 1.0f - w * w));
    float3 bu, bv;
    basis_around(a, &bu, &bv);
    float ph = 2.0f * 3.14159265358979f * u2;
    return normalize(r * cos(ph) * bu + r * sin(ph) * bv + w * a);
}

inline float vmf_pdf(float3 a, float kappa, float3 x) {
    return vmf_to_sg_mu(kappa) * exp(kappa * (dot(a, x) - 1.0f));
}

__kernel void fis_shade(FIS_SHADE_ARGS)
{
    SHADE_PIXEL_PROLOGUE;
    int mi = OBJ_MAT(ob);

    int4 ndf = ndf_info[mi];
    int nl = ndf.w ? min((int)m[MAT_NLOBES], MAX_NDF_LOBES) : 0;
    float3 col = (float3)(0.0f);
    float wsum = 0.0f;
    float lw[MAX_NDF_LOBES];
    float4 la[MAX_NDF_LOBES];     /* the pixel's lobes (axis, λ), read (interpolated) once */
    for (int j = 0; j < nl; ++j) {
        float4 L0, L1;
        ndf_lobe(lobes, m, j, 0.0f, &L0, &L1);
        la[j] = (float4)(normalize(L0.xyz), L0.w);
        lw[j] = L1.x * sg_integral_unit(L0.w);
        wsum += lw[j];
    }
    /* The specular lobe's N samples: 3/4 from the NDF lobes (vMF), 1/4 cosine-weighted as a
     * defensive mixture for the NDF's tails (multi-sample balance heuristic). The diffuse term
     * uses the irradiance form as C&K do (here: the SG light fit with SSDF visibility, eq 39). */
    int ns = 0, nd = 0;
    if (nl > 0 && wsum > 0.0f) {
        nd = nsamp >= 4 ? nsamp / 4 : 0;
        ns = nsamp - nd;
    }
    if (!(flags & FLAG_NO_ENV_DIFFUSE))
        col += diffuse_env_sg(m, kd, op, q, qi, T, B, N, env_sg, n_env_sg, env_scale, &vis);
    float rot1 = 0.0f, rot2 = 0.0f;      /* seed ≠ 0: per-pixel Cranley–Patterson rotation */
    if (seed != 0u) {
        uint hsh = hash_u32((uint)gid * 0x9E3779B9u ^ seed);
        rot1 = (float)(hsh & 0xFFFFu) / 65536.0f;
        rot2 = (float)(hash_u32(hsh) & 0xFFFFu) / 65536.0f;
    }
    int N0 = mip_res[0];
    for (int s = 0; s < ns + nd && !(flags & FLAG_NO_ENV_SPECULAR); ++s) {
        int spec = s < ns;
        int si = spec ? s : s - ns, cnt = spec ? ns : nd;
        float u1 = ((float)si + 0.5f) / (float)cnt + rot1, u2 = radical_inverse2((uint)si) + rot2;
        u1 -= floor(u1); u2 -= floor(u2);
        float3 ip;   /* in the BRDF (normal-mapped) frame */
        if (spec) {
            /* choose a lobe by its mass (u1 reused, stratified within the chosen lobe) */
            float acc = 0.0f, pick = u1 * wsum;
            int j = 0;
            for (; j < nl - 1; ++j) { if (pick < acc + lw[j]) break; acc += lw[j]; }
            float uu = clamp((pick - acc) / fmax(lw[j], 1e-30f), 0.0f, 0.99999f);
            float3 h = vmf_sample(la[j].xyz, la[j].w, uu, u2);
            ip = 2.0f * dot(op, h) * h - op;
        } else {
            float r = sqrt(u1), ph = 2.0f * 3.14159265358979f * u2;
            ip = (float3)(r * cos(ph), r * sin(ph), sqrt(fmax(0.0f, 1.0f - u1)));
        }
        if (ip.z <= 0.0f) continue;
        ip = normalize(ip);
        float3 h = normalize(op + ip);
        float oh = dot(op, h);
        float ph_h = 0.0f;
        for (int j = 0; j < nl; ++j) {
            ph_h += lw[j] / wsum * vmf_pdf(la[j].xyz, la[j].w, h);
        }
        float p_s = oh > 0.0f ? ph_h / (4.0f * oh) : 0.0f;
        float p_d = ip.z * 0.318309886f;
        float denom = (float)ns * p_s + (float)nd * p_d;
        if (denom <= 0.0f) continue;
        float3 ig = quat_rotate(q, ip);
        if (ig.z <= 0.0f) continue;
        if (!(flags & FLAG_NO_VISIBILITY) && vis_theta(&vis, ig) <= 0.0f) continue;
        float3 f = mf_M(m, tables, ks, op, ip) * ndf_exact(m, tables, ndf, h);
        float3 iw = normalize(to_world(ig, T, B, N));
        float omega_s = 1.0f / denom;   /* = 1/(N p) */
        float lod = fmax(0.5f * log2(omega_s / cube_texel_solid_angle(iw, N0)) + 1.0f, 0.0f);
        float3 L = env_scale * cube_mip(mip, mip_off, mip_res, mip_n, iw, lod);
        col += f * L * ip.z / denom;
    }
    for (int l = 0; l < n_lights; ++l) {
        SG Lw = light_sg(lights[2 * l], lights[2 * l + 1], x);
        float3 lg = to_local(Lw.p, T, B, N);
        float3 lp = quat_rotate(qi, lg);
        if (lp.z <= 0.0f || lg.z <= 0.0f) continue;
        if (!(flags & FLAG_NO_VISIBILITY) && vis_theta(&vis, lg) <= 0.0f) continue;
        float3 h = normalize(op + lp);
        float3 f = mf_diffuse(m, kd, op, lp);
        if (nl > 0) f += mf_M(m, tables, ks, op, lp) * ndf_exact(m, tables, ndf, h);
        col += f * lp.z * sg_integral(Lw);
    }
    out[gid] = (float4)(col, 1.0f);
}
