/* Method `transport`: Green06 rendering (§5) of G-buffer pixels from the transport stage.
 *   glossy  Σ_k w_k · Γ_L(μ_k, 1/σ_k²)     (eq 4 integrated against the lighting, eq 1)
 *   diffuse f_d · Σ_j L_j t_j               (§6.1, shadowed PRT, 25 SH coefficients)
 * Per pixel, each vertex of the hit triangle gets its Gaussians interpolated across the three
 * views around the pixel's view direction, then the three are blended barycentrically
 * (transport.h, mirroring sgpipe.transport.interp). Green06's G(ω) = exp((ω·μ − 1)/σ²) is the
 * SG of sg.h with p = μ, λ = 1/σ², amplitude w, so ∫ w G L dω = w Γ_L(μ, 1/σ²) — one accurate
 * pyramid lookup (cubemap.h gamma_lookup_acc + the point set), as `sg` does.
 * tp_obj per object: (first vertex row, first face, Gaussians K, has data). */
#include "sg.h"
#include "cubemap.h"
#include "records.h"
#include "methods.h"
#include "transport.h"

__kernel void transport_shade(TRANSPORT_SHADE_ARGS)
{
    int gid = get_global_id(0);
    if (gid >= n) return;
    int4 to = tp_obj[gobj[gid]];
    int tri = gtri[gid];
    float3 rd = (float3)(0.0f), rs = (float3)(0.0f);
    if (to.w != 0 && tri >= 0) {
        __global const int *f = tp_faces + 3 * (to.y + tri);
        int vert[3] = {to.x + f[0], to.x + f[1], to.x + f[2]};
        float2 bc = gbary[gid];
        float bt[3] = {1.0f - bc.x - bc.y, bc.x, bc.y};
        if (!(flags & FLAG_NO_ENV_SPECULAR)) {
            int iv[3];
            float bv[3];
            tp_nearest_views(gview[gid].xyz, tp_vinv, tp_vtri, iv, bv);
            int K = min(to.z, TP_MAX_K);
            for (int k = 0; k < K; ++k) {
                float3 mu[3], w[3];
                float sig[3];
                for (int i = 0; i < 3; ++i)
                    tp_vertex_gaussian(tp_gauss, vert[i], K, k, iv, bv, &mu[i], &sig[i], &w[i]);
                float3 m, ww;
                float s;
                tp_blend(mu, sig, w, bt, &m, &s, &ww);
                if (s <= 0.0f || (ww.x == 0.0f && ww.y == 0.0f && ww.z == 0.0f)) continue;
                float lam = 1.0f / (s * s);
                rs += ww * env_scale * (gamma_lookup_acc(pyr, pyr_off, pyr_res, pyr_lam, pyr_n,
                                                         pyr_log_ratio, env_mean.xyz, pyr_raw,
                                                         raw_n, m, lam)
                                        + gamma_points(pyr_pts, n_pts, m, lam));
            }
        }
        if (!(flags & FLAG_NO_ENV_DIFFUSE)) {
            /* the transfer vector is linear: blend it, then one dot product with the light
               per colour channel (interreflected transfer is RGB: tp_sh is (X, 25, 3)) */
            for (int j = 0; j < tp_sh_n; ++j) {
                float3 t = bt[0] * vload3(vert[0] * 25 + j, tp_sh)
                           + bt[1] * vload3(vert[1] * 25 + j, tp_sh)
                           + bt[2] * vload3(vert[2] * 25 + j, tp_sh);
                rd += t * tp_light_sh[j].xyz;
            }
            rd *= tp_fd[gobj[gid]].xyz * env_scale;
        }
    }
    out[gid] = (float4)(rd + rs, 1.0f);
}
