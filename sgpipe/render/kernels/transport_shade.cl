/* Methods `transport` and `transport_green06`: Green06 rendering (§5) of G-buffer pixels from
 * the transport stage.
 *   glossy  Σ_k w_k · Γ_L(μ_k, 1/σ_k²)     (eq 4 integrated against the lighting, eq 1)
 *   diffuse f_d · Σ_j L_j t_j               (§6.1, shadowed PRT, 25 SH coefficients)
 * Per pixel, each vertex of the hit triangle gets its Gaussians interpolated across the three
 * views around the pixel's view direction, then the three are blended barycentrically
 * (transport.h, mirroring sgpipe.transport.interp). Green06's G(ω) = exp((ω·μ − 1)/σ²) is the
 * SG of sg.h with p = μ, λ = 1/σ², amplitude w, so ∫ w G L dω = w Γ_L(μ, 1/σ²) — one accurate
 * pyramid lookup (cubemap.h gamma_lookup_acc), as `sg` does.
 * Departures of `transport` (methods.GREEN06_SWITCHES; `transport_green06` compiles with
 * TP_NO_RATIO and TP_GAUSSIAN_POINTS, Green06 as published):
 * - The environment's glossy part, where the stage stored the unshadowed Gaussians too
 *   (transport.sampling: lobe), is the BRDF's own lobes at the pixel (sg_specular.h, no SSDF)
 *   times the ratio of the shadowed to the unshadowed Gaussians' Γ_L under the same light: the
 *   Gaussians carry only the occlusion, the lobe's shape and its place at the pixel's exact
 *   normal and view come from the BRDF. Nothing occluding: the ratio is exactly 1.
 * - Delta light (the environment's point set, lights sharper than SHARP_LIGHT), where the
 *   material has its NDF table: the exact specular BRDF at the light's direction times the
 *   light's SSDF horizon (shading.h points_exact_specular, as `sg` shades it); a Gaussian
 *   fitted to the lobe keeps the lobe's integral but not its value at one direction.
 * - An object with SSDF visibility takes the point set out of its PRT: the SH light is then the
 *   map minus the points, and the points, merged into small lights k (direction c_k, energy
 *   E_k, sharpness λ_k from their spread: transport_data.merge_points), add
 *   f_d E_k max(0, n·c_k) f̂_h(θ_d(c_k), λ_k), the SSDF horizon (eq 46) of an SG light, because
 *   25 coefficients cannot hold a sun's shadow; the points' share of the interreflected
 *   transfer stays in SH (it is smooth). tp_light_sh: 25 rows of the whole map, 25 of the map
 *   minus the points, 25 of the points alone (transport_data.py).
 * Local lights (render.lights): see tp_light_glossy and shading.h sg_light_diffuse.
 * Textured materials: the BRDF's lobes, the delta lights' exact BRDF and the diffuse colour
 * f_d are the pixel's own (pixel_init's record from the filtered textures); the Gaussians
 * (the ratio's occlusion, and `transport_green06`'s glossy part, Green06 Fig 1's spatially
 * varying material) are the stage's, each vertex's fitted with its own material (the textures
 * filtered to the vertex spacing, transport.vertex_materials) and blended like any others:
 * `transport_green06`'s glossy colour and roughness vary at the mesh's resolution.
 * tp_obj per object: (first vertex row, first face, Gaussians K, TP_HAS_* bits). */
#include "sg.h"
#include "asg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"   /* records.h, methods.h, the SSDF state Vis */
/* the lobes' own energy: transport's visibility ratio R scales E_pix as sg's lobes give it
 * (render.energy's table is sg's) */
#define SG_NO_ENERGY 1
#include "sg_specular.h"
#include "transport.h"

#define TP_HAS_INDIRECT 2      /* tp_obj.w bit: tp_sh_ind holds the interreflected transfer */
#define TP_HAS_OPEN 4          /* tp_obj.w bit: tp_gauss_open holds the unshadowed Gaussians */
#define TP_RATIO_FLOOR 0.01f   /* the ratio's uniform light, × the map's mean */
#define TP_RATIO_MAX_INDIRECT 4.0f  /* the ratio's cap when the Gaussians hold T^IG */

/* ⟨G, L⟩ / w of the Gaussian (m, λ) under the environment: the Γ_L chain, plus the point set's
 * value unless the caller shades it exactly. */
#define TP_ENV_ARGS pyr, pyr_off, pyr_res, pyr_lam, pyr_n, pyr_log_ratio, env_mean, pyr_raw, \
                    raw_n, pyr_pts, n_pts
inline float3 tp_env_lookup(__global const float4 *pyr, __global const int *pyr_off,
                            __global const int *pyr_res, __global const float *pyr_lam,
                            int pyr_n, float pyr_log_ratio, float4 env_mean,
                            __global const float4 *pyr_raw, int raw_n,
                            __global const float4 *pyr_pts, int n_pts, int exact_pts,
                            float3 m, float lam) {
    return gamma_lookup_acc(pyr, pyr_off, pyr_res, pyr_lam, pyr_n, pyr_log_ratio, env_mean.xyz,
                            pyr_raw, raw_n, m, lam)
           + (exact_pts ? (float3)(0.0f) : gamma_points(pyr_pts, n_pts, m, lam));
}

/* Local lights (render.lights) as the SGs of light_sg (sg's eq 42–43 form; distant-light
 * transport as the Gaussians were fitted, visibility by the SSDF): glossy w·⟨G, L⟩ per Gaussian
 * (a light sharper than SHARP_LIGHT: w·G(l)·∫L), diffuse shading.h's sg_light_diffuse
 * (f_d E max(0, n·l) f̂_h(θ_d(l), λ_L) when sharp, else f_d (C* ⊗ L)·V^d; eq 42). */
inline float3 tp_light_glossy(float3 m, float lam, SG L) {
    if (L.lam >= SHARP_LIGHT)
        return exp(lam * (dot(m, L.p) - 1.0f)) * sg_integral(L);
    return sg_inner(sg_make(m, lam, (float3)(1.0f)), L);
}

__kernel void transport_shade(TRANSPORT_SHADE_ARGS)
{
    int gid = get_global_id(0);
    if (gid >= n) return;
    int4 to = tp_obj[gobj[gid]];
    int tri = gtri[gid];
    float3 rd = (float3)(0.0f), rs = (float3)(0.0f);
    if (to.w != 0 && tri >= 0) {
        Pixel px = pixel_init(gid, gnrm, gtan, gview, gpos, guv, gobj, objs, mats, texels,
                              texinfo, texaff, gduv, pxmat);
        float3 N = px.N, T = px.T, B = px.B, x = px.x;
        Vis vis;
        vis_init(&vis, px.ob, OBJF_MAXD(objf[gobj[gid]]), tri, gbary[gid], vfaces, coeffs,
                 ssdf_data, !(flags & FLAG_NO_VISIBILITY));
#ifdef TP_GAUSSIAN_POINTS
        int4 ndf = (int4)(0);
#else
        int4 ndf = ndf_info[OBJ_MAT(px.ob)];
#endif
        __global const int *f = tp_faces + 3 * (to.y + tri);
        int vert[3] = {to.x + f[0], to.x + f[1], to.x + f[2]};
        float2 bc = gbary[gid];
        float bt[3] = {1.0f - bc.x - bc.y, bc.x, bc.y};
        int env_spec = !(flags & FLAG_NO_ENV_SPECULAR);
        int exact_pts = ndf.w && env_spec;
        if (exact_pts)
            rs += points_exact_specular(pyr_pts, n_pts, px.m, tables, ndf, px.ks, px.op, px.qi,
                                        T, B, N, &vis, env_scale);
        /* the glossy visibility ratio needs the unshadowed Gaussians (sampling: lobe) */
#ifdef TP_NO_RATIO
        int ratio = 0;
#else
        int ratio = env_spec && (to.w & TP_HAS_OPEN);
#endif
        if (env_spec || n_lights > 0) {
            int iv[3];
            float3 S = (float3)(0.0f), U = (float3)(0.0f);   /* ⟨G, L⟩: shadowed, open */
            float3 S0 = (float3)(0.0f), U0 = (float3)(0.0f); /* their integrals ∫G / 2π */
            float bv[3];
            tp_nearest_views(gview[gid].xyz, tp_vinv, tp_vtri, iv, bv);
            int K = min(to.z, TP_MAX_K);
            for (int k = 0; k < K; ++k) {
                float3 mu[3], w[3];
                float sig[3];
                float3 m, ww;
                float s;
                if (ratio) {
                    for (int i = 0; i < 3; ++i)
                        tp_vertex_gaussian(tp_gauss_open, vert[i], K, k, iv, bv, &mu[i],
                                           &sig[i], &w[i]);
                    tp_blend(mu, sig, w, bt, &m, &s, &ww);
                    if (s > 0.0f) {
                        U += ww * tp_env_lookup(TP_ENV_ARGS, exact_pts, m, 1.0f / (s * s));
                        U0 += ww * tp_lobe_area(s);
                    }
                }
                for (int i = 0; i < 3; ++i)
                    tp_vertex_gaussian(tp_gauss, vert[i], K, k, iv, bv, &mu[i], &sig[i], &w[i]);
                tp_blend(mu, sig, w, bt, &m, &s, &ww);
                if (s <= 0.0f || (ww.x == 0.0f && ww.y == 0.0f && ww.z == 0.0f)) continue;
                float lam = 1.0f / (s * s);
                if (env_spec) {
                    float3 look = tp_env_lookup(TP_ENV_ARGS, exact_pts, m, lam);
                    if (ratio) {
                        S += ww * look;
                        S0 += ww * tp_lobe_area(s);
                    } else {
                        rs += ww * env_scale * look;
                    }
                }
                for (int l = 0; l < n_lights; ++l) {
                    SG L = light_sg(lights[2 * l], lights[2 * l + 1], x);
                    if (ndf.w && L.lam >= SHARP_LIGHT) continue;       /* exact below */
                    rs += ww * tp_light_glossy(m, lam, L);
                }
            }
            if (ratio) {
                /* the environment's glossy part: the BRDF's own lobes at the pixel (sg's
                 * sg_lobes_specular with no SSDF: the tangent plane's horizon only) times the
                 * fitted transport's visibility, the ratio of the shadowed to the unshadowed
                 * Gaussians under the same lighting. A faint uniform light (TP_RATIO_FLOOR of
                 * the map's mean) in both keeps the ratio defined where the lobe sees black:
                 * there it tends to the ratio of the lobes' integrals, the visible fraction. */
                float3 floor_l = TP_RATIO_FLOOR * env_mean.xyz;
                float3 den = U + floor_l * U0;
                float3 R = (float3)(den.x > 0.0f ? (S.x + floor_l.x * S0.x) / den.x : 0.0f,
                                    den.y > 0.0f ? (S.y + floor_l.y * S0.y) / den.y : 0.0f,
                                    den.z > 0.0f ? (S.z + floor_l.z * S0.z) / den.z : 0.0f);
                /* ... at most the visible share of the lobes' integral: one Gaussian fitted
                 * to a clipped lobe sits in the visible part, and where that part sees brighter
                 * light than the hidden one (a lamp above a bowl's rim) the light-weighted
                 * ratio overshoots */
                float3 Ri = (float3)(U0.x > 0.0f ? S0.x / U0.x : 0.0f,
                                     U0.y > 0.0f ? S0.y / U0.y : 0.0f,
                                     U0.z > 0.0f ? S0.z / U0.z : 0.0f);
                R = fmin(R, Ri);
                /* occlusion only removes light; indirect transport (T^IG) can add some */
                R = clamp(R, 0.0f, (to.w & TP_HAS_INDIRECT) ? TP_RATIO_MAX_INDIRECT : 1.0f);
                Vis open;
                vis_init(&open, px.ob, OBJF_MAXD(objf[gobj[gid]]), tri, gbary[gid], vfaces,
                         coeffs, ssdf_data, 0);
                float3 none[1];
                rs += R * sg_lobes_specular(px.m, lobes, tables, px.ks, px.op, px.q, px.qi, T, B,
                                            N, x, &open, 1, exact_pts, ndf.w, pyr, pyr_off,
                                            pyr_res, pyr_lam, pyr_n, pyr_log_ratio, env_mean,
                                            pyr_raw, raw_n, pyr_pts, n_pts, env_scale, lights,
                                            0, none, 0.0f);
            }
        }
        int env_diff = !(flags & FLAG_NO_ENV_DIFFUSE);
        if (env_diff || n_lights > 0) {
            int split = vis.has && tp_n_suns > 0;
            if (env_diff) {
                __global const float4 *L = tp_light_sh + (split ? 25 : 0);
                int ind = split && (to.w & TP_HAS_INDIRECT);
                /* the transfer vector is linear: blend it, then one dot product with the light
                   per colour channel (interreflected transfer is RGB: tp_sh is (X, 25, 3)) */
                for (int j = 0; j < tp_sh_n; ++j) {
                    float3 t = bt[0] * vload3(vert[0] * 25 + j, tp_sh)
                               + bt[1] * vload3(vert[1] * 25 + j, tp_sh)
                               + bt[2] * vload3(vert[2] * 25 + j, tp_sh);
                    rd += t * L[j].xyz;
                    if (ind)
                        rd += (bt[0] * vload3(vert[0] * 25 + j, tp_sh_ind)
                               + bt[1] * vload3(vert[1] * 25 + j, tp_sh_ind)
                               + bt[2] * vload3(vert[2] * 25 + j, tp_sh_ind))
                              * tp_light_sh[50 + j].xyz;
                }
                for (int k = 0; split && k < tp_n_suns; ++k) {
                    float4 a = tp_suns[2 * k];
                    float3 c = to_local(a.xyz, T, B, N);
                    if (c.z > 0.0f)
                        rd += tp_suns[2 * k + 1].xyz * (c.z * fh_hat(vis_theta(&vis, c), a.w));
                }
                rd *= env_scale;
            }
            SG cosg = sg_clamped_cosine((float3)(0.0f, 0.0f, 1.0f));
            float4 q0 = (float4)(0.0f, 0.0f, 0.0f, 1.0f);    /* no normal map */
            float3 rl = (float3)(0.0f);
            for (int l = 0; l < n_lights; ++l) {
                SG Lw = light_sg(lights[2 * l], lights[2 * l + 1], x);
                float3 fdir;
                float3 E = sg_light_diffuse(sg_make(to_local(Lw.p, T, B, N), Lw.lam, Lw.mu),
                                            cosg, q0, &vis, &fdir);
                rl += E;
                /* a sharp light's glossy part: the exact specular BRDF at its direction */
                if (ndf.w && Lw.lam >= SHARP_LIGHT && fdir.z > 0.0f)
                    rs += sharp_light_specular(E, px.m, tables, ndf, px.ks, px.op, fdir);
            }
            /* f_d at normal incidence, as the stage stores the object's in tp_fd: a textured
             * material's from the pixel's own record (pixel_init: its filtered base colour,
             * metalness or kd texture) */
            float3 z = (float3)(0.0f, 0.0f, 1.0f);
            float3 fd = px.m[MAT_SV] > 0.5f || (int)px.m[MAT_KDTEX] >= 0
                        ? mf_diffuse(px.m, px.kd, z, z) : tp_fd[gobj[gid]].xyz;
            rd = (rd + rl) * fd;
        }
    }
    out[gid] = (float4)(rd + rs, 1.0f);
}
