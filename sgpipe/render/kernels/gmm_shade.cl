/* Method `gmm` (paper 000 §V): per pixel the view direction in tangent space selects the
 * fitted per-view vMF mixture ρ(i, o_j)(n·i) ≈ Σ_k α_k vMF(i; μ_k, κ_k) (eq 3) — nearest view,
 * or bilinear across views when the fit is coherent — and each lobe is integrated against the
 * environment by ONE box-MIP lookup at the lobe's level (eq 6–10, cube distortion):
 *   L_o ≈ Σ_k α_k · L_mip(μ_k, lod(κ_k)) [· f̂_h(θ_d(μ_k), κ_k) with baseline shadows].
 * Diffuse not inside the lobes (includes_diffuse = 0), and purely diffuse materials, use the SG
 * light fit (Wang09 eq 39); local lights use the mixture itself: ρ cos ≈ Σ α vMF(l) times the irradiance.
 * Defines: NV, FH_*, MAX_GMM_LOBES. */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"

#define GMM_NT 27
#define GMM_NP 28
#define GMM_K 29
#define GMM_TMAX 30
#define GMM_FLAGS 31

/* Lobe k of view (t, p): α RGB, κ, axis (local BRDF frame; iso fits rotated to azimuth phi0). */
inline void gmm_lobe(__global const float4 *gmm, int base, int np, int K, int t, int p, int k,
                     float phi_view, float3 *alpha, float *kappa, float3 *axis) {
    int row = base + 2 * ((t * np + p) * K + k);
    float4 a = gmm[row], b = gmm[row + 1];
    *alpha = a.xyz;
    *kappa = a.w;
    float phi = phi_view + 3.14159265358979f + b.y;
    float st = sin(b.x);
    *axis = (float3)(st * cos(phi), st * sin(phi), cos(b.x));
}

__kernel void gmm_shade(
    const int n,
    __global const float4 *gnrm, __global const float4 *gtan, __global const float4 *gview,
    __global const float4 *gpos, __global const float2 *guv,
    __global const int *gobj, __global const int *gtri, __global const float2 *gbary,
    __global const int8 *objs, __global const float4 *objf,
    __global const int *vfaces, __global const float *coeffs,
    __global const float *ssdf_data,
    __global const float *mats, __global const float4 *lobes, __global const float *tables,
    __global const float4 *texels, __global const int4 *texinfo,
    __global const float4 *gmm, __global const int4 *ndf_info,
    __global const float4 *mip, __global const int *mip_off, __global const int *mip_res,
    const int mip_n,
    __global const float4 *env_sg, const int n_env_sg, const float env_scale,
    const float coverage,
    __global const float4 *lights, const int n_lights,
    const int interp, const int flags,
    __global float4 *out)
{
    int gid = get_global_id(0);
    if (gid >= n) return;
    Pixel px = pixel_init(gid, gnrm, gtan, gview, gpos, guv, gobj, objs, mats, texels, texinfo);
    float3 N = px.N, T = px.T, B = px.B, x = px.x, kd = px.kd, ks = px.ks, op = px.op;
    float4 q = px.q, qi = px.qi;
    int8 ob = px.ob;
    __global const float *m = px.m;
    /* Textures scale the fitted lobes by the texel / base-colour ratio (SVBRDF). */
    float3 ks0 = mat3(m, MAT_KS), kd0 = mat3(m, MAT_KD);
    float3 ks_ratio = select((float3)(1.0f), ks / ks0, isgreater(ks0, (float3)(0.0f)));
    float3 kd_ratio = select((float3)(1.0f), kd / kd0, isgreater(kd0, (float3)(0.0f)));

    Vis vis;   /* PCA coefficients interpolated over the SSDF mesh triangle (eq 24) */
    vis_init(&vis, ob, objf[gobj[gid]].x, gtri[gid], gbary[gid], vfaces, coeffs, ssdf_data,
             !(flags & 4));

    float3 col = (float3)(0.0f);
    int base = (int)m[MAT_GMM];
    int gflags = (int)m[GMM_FLAGS];
    int with_diffuse_lobes = (gflags & 2) != 0;
    /* A purely diffuse material's "slice" is the broad cosine lobe, far coarser than a lobe-sized
     * MIP lookup can resolve: it takes the irradiance form (SG light fit) like the diffuse part
     * of every other material. */
    if (with_diffuse_lobes && (int)m[MAT_NLOBES] == 0) { base = -1; with_diffuse_lobes = 0; }
    if (base >= 0) {
        int nt = (int)m[GMM_NT], np = (int)m[GMM_NP], K = min((int)m[GMM_K], MAX_GMM_LOBES);
        float th = acos(clamp(op.z, -1.0f, 1.0f));
        float ph = atan2(op.y, op.x);
        if (ph < 0.0f) ph += 2.0f * 3.14159265358979f;
        float tc = clamp(th / fmax(m[GMM_TMAX], 1e-6f) * (float)(nt - 1), 0.0f, (float)(nt - 1));
        float pc = np > 1 ? ph / (2.0f * 3.14159265358979f) * (float)np : 0.0f;
        int coherent = (gflags & 1) && interp;
        int t0 = coherent ? min((int)floor(tc), max(nt - 2, 0)) : (int)(tc + 0.5f);
        float ft = coherent && nt > 1 ? tc - (float)t0 : 0.0f;
        int p0 = coherent ? (int)floor(pc) : (int)(pc + 0.5f);
        float fp = coherent && np > 1 ? pc - floor(pc) : 0.0f;
        p0 = np > 1 ? p0 % np : 0;
        int t1 = min(t0 + 1, nt - 1), p1 = np > 1 ? (p0 + 1) % np : 0;
        float w[4] = {(1 - ft) * (1 - fp), ft * (1 - fp), (1 - ft) * fp, ft * fp};
        int tt[4] = {t0, t1, t0, t1}, pp[4] = {p0, p0, p1, p1};
        for (int k = 0; k < K; ++k) {
            float3 alpha = (float3)(0.0f), axis = (float3)(0.0f);
            float kappa = 0.0f;
            for (int c = 0; c < 4; ++c) {
                if (w[c] <= 0.0f) continue;
                float phv = np > 1 ? 2.0f * 3.14159265358979f * (float)pp[c] / (float)np : ph;
                float3 a, ax; float kp;
                gmm_lobe(gmm, base, np, K, tt[c], pp[c], k, phv, &a, &kp, &ax);
                alpha += w[c] * a; kappa += w[c] * kp; axis += w[c] * ax;
            }
            if (kappa <= 0.0f || dot(axis, axis) < 1e-12f) continue;
            axis = normalize(axis);
            float3 ag = quat_rotate(q, axis);
            float3 aw = normalize(to_world(ag, T, B, N));
            float3 scale = with_diffuse_lobes ? kd_ratio : ks_ratio;
            float vis_f = (flags & 4) ? 1.0f : fh_hat(vis_theta(&vis, ag), kappa);
            float lod = cube_lobe_lod(aw, kappa, coverage, mip_res[0]);
            if (!(flags & 2))
                col += alpha * scale * vis_f * env_scale * cube_mip(mip, mip_off, mip_res, mip_n, aw, lod);
            for (int l = 0; l < n_lights; ++l) {
                SG Lw = light_sg(lights[2 * l], lights[2 * l + 1], x);
                float3 lg = to_local(Lw.p, T, B, N);
                float3 E = sg_integral(Lw);
                float pdf = vmf_to_sg_mu(kappa) * exp(kappa * (dot(axis, quat_rotate(qi, lg)) - 1.0f));
                float v = (flags & 4) ? 1.0f : fh_hat(vis_theta(&vis, lg), Lw.lam);
                col += alpha * scale * pdf * E * v;
            }
        }
    }
    /* Diffuse outside the fitted slice: Wang09 eq 39 with the SG light fit (+ lights). */
    if (!with_diffuse_lobes) {
        SG cosg = sg_clamped_cosine(quat_rotate(q, (float3)(0.0f, 0.0f, 1.0f)));
        if (!(flags & 1))
            col += diffuse_env_sg(m, kd, op, q, qi, T, B, N, env_sg, n_env_sg, env_scale, &vis);
        for (int l = 0; l < n_lights; ++l) {
            SG Lw = light_sg(lights[2 * l], lights[2 * l + 1], x);
            SG g = sg_product(cosg, sg_make(to_local(Lw.p, T, B, N), Lw.lam, Lw.mu));
            float3 fd = mf_diffuse(m, kd, op, lift(quat_rotate(qi, g.p), 0.05f));
            col += fd * sg_dot_visibility(g, vis_theta(&vis, g.p));
        }
    }
    out[gid] = (float4)(col, 1.0f);
}
