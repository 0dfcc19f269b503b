/* Method `sg`: Wang09 §7 full shading of G-buffer pixels.
 *   diffuse   R_d = Σ_k f_d · (C* ⊗ L*_k) · V^d                  (eq 39)
 *   specular  R_s = Σ_j ((C* ⊗ ρ*_s,j ⊗ V^d) · L) via Γ_L           (eq 41, warp eq 22)
 *   lights    (L*_x ⊗ C*) · V^d and (L*_x ⊗ C* ⊗ ρ*_s) · V^d       (eq 42–43, lights eq 32–33)
 * with per-pixel SSDF decoding from interpolated PCA coefficients (eq 24, 30–31) and normal
 * maps as quaternion rotations of C* and ρ*_s (§7). Defines: NV (PCA terms, stride of the
 * coefficient rows), FH_A, FH_C3..FH_C0 (f_h sigmoid), MAX_NDF_LOBES. */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"   /* also SHARP_LIGHT */

__kernel void sg_shade(
    const int n,
    __global const float4 *gnrm, __global const float4 *gtan, __global const float4 *gview,
    __global const float4 *gpos, __global const float2 *guv,
    __global const int *gobj, __global const int *gtri, __global const float2 *gbary,
    __global const int8 *objs, __global const float4 *objf,
    __global const int *vfaces, __global const float *coeffs,
    __global const float *ssdf_data,
    __global const float *mats, __global const float4 *lobes, __global const float *tables,
    __global const float4 *texels, __global const int4 *texinfo,
    __global const float4 *pyr, __global const int *pyr_off, __global const int *pyr_res,
    __global const float *pyr_lam, const int pyr_n, const float pyr_log_ratio, const float4 env_mean,
    __global const float4 *env_sg, const int n_env_sg, const float env_scale,
    __global const float4 *lights, const int n_lights,
    const int flags,
    __global float4 *out)
{
    int gid = get_global_id(0);
    if (gid >= n) return;
    Pixel px = pixel_init(gid, gnrm, gtan, gview, gpos, guv, gobj, objs, mats, texels, texinfo);
    float3 N = px.N, T = px.T, B = px.B, x = px.x, kd = px.kd, ks = px.ks, op = px.op;
    float4 q = px.q, qi = px.qi;
    int8 ob = px.ob;
    __global const float *m = px.m;
    Vis vis;   /* PCA coefficients interpolated over the SSDF mesh triangle (eq 24) */
    vis_init(&vis, ob, objf[gobj[gid]].x, gtri[gid], gbary[gid], vfaces, coeffs, ssdf_data,
             !(flags & 4));
    SG cosq = sg_clamped_cosine((float3)(0.0f, 0.0f, 1.0f));   /* C*(z+) of the rotated frame */
    SG cosg = cosq; cosg.p = quat_rotate(q, cosq.p);             /* ... in the geometric frame */

    /* BRDF slice ρ*_s(i; o') as warped SG lobes (eq 22), already ⊗ C*, in the geometric frame. */
    int nl = min((int)m[MAT_NLOBES], MAX_NDF_LOBES);
    SG spec[MAX_NDF_LOBES], specw[MAX_NDF_LOBES];   /* C* ⊗ ρ*_s,j and ρ*_s,j (geometric frame) */
    for (int j = 0; j < nl; ++j) {
        float4 L0 = lobes[2 * ((int)m[MAT_LOBE0] + j)];
        float4 L1 = lobes[2 * ((int)m[MAT_LOBE0] + j) + 1];
        SG w = sg_warp(sg_make(normalize(L0.xyz), L0.w, (float3)(L1.x)), op);
        w.mu *= mf_M(m, tables, ks, op, lift(w.p, 0.05f));
        specw[j] = w;
        specw[j].p = quat_rotate(q, w.p);
        SG s = sg_product(cosq, w);
        s.p = quat_rotate(q, s.p);
        spec[j] = s;
    }

    float3 rd = (float3)(0.0f), rs = (float3)(0.0f);
    /* Environment, diffuse (eq 39). */
    if (!(flags & 1))
        rd += diffuse_env_sg(m, kd, op, q, qi, T, B, N, env_sg, n_env_sg, env_scale, &vis);
    /* Environment, specular (eq 41): ⊗ V^d (eq 31), rotate to world, Γ_L lookup (eq 35). */
    if (!(flags & 2)) {
        for (int j = 0; j < nl; ++j) {
            SG s = sg_times_visibility(spec[j], vis_theta(&vis, spec[j].p));
            float3 pw = normalize(to_world(s.p, T, B, N));
            rs += s.mu * env_scale * gamma_lookup(pyr, pyr_off, pyr_res, pyr_lam, pyr_n,
                                                  pyr_log_ratio, env_mean.xyz, pw, s.lam);
        }
    }
    /* Local lights (eq 42–43), in the local frame. A light much sharper than the cosine lobe
     * (λ_L ≥ SHARP_LIGHT) uses the limit of the products, E·max(0, n·l)·ρ*(l)·f̂_h(θ_d(l), λ_L):
     * C*'s peak 1.17 would otherwise brighten small lights by up to 17%. */
    for (int k = 0; k < n_lights; ++k) {
        SG Lw = light_sg(lights[2 * k], lights[2 * k + 1], x);
        SG L = sg_make(to_local(Lw.p, T, B, N), Lw.lam, Lw.mu);
        if (L.lam >= SHARP_LIGHT) {
            float3 lp = quat_rotate(qi, L.p);
            if (lp.z <= 0.0f || L.p.z <= 0.0f) continue;
            float3 E = sg_integral(L) * (lp.z * fh_hat(vis_theta(&vis, L.p), L.lam));
            float3 f = mf_diffuse(m, kd, op, lp);
            for (int j = 0; j < nl; ++j) f += sg_eval(specw[j], L.p);
            rd += f * E;
            continue;
        }
        SG g = sg_product(L, cosg);
        float3 fd = mf_diffuse(m, kd, op, lift(quat_rotate(qi, g.p), 0.05f));
        rd += fd * sg_dot_visibility(g, vis_theta(&vis, g.p));
        for (int j = 0; j < nl; ++j) {
            SG s = sg_product(L, spec[j]);
            rs += sg_dot_visibility(s, vis_theta(&vis, s.p));
        }
    }
    out[gid] = (float4)(rd + rs, 1.0f);
}
