/* Thin kernels exposing the shared headers' math to the test-suite (tests/render/test_sg_*.py
 * compare them with sgpipe.core and the upstream Python readers). Not used for rendering. */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"

/* a, b: lobes as float8 (p.xyz, λ, μ.xyz, 0). out: product (float8), inner (float4),
 * warp of a for view o (float8). */
__kernel void t_sg(__global const float8 *a, __global const float8 *b, __global const float4 *o,
                   __global float8 *prod, __global float4 *inner, __global float8 *warp) {
    int i = get_global_id(0);
    SG ga = sg_make(a[i].s012, a[i].s3, a[i].s456), gb = sg_make(b[i].s012, b[i].s3, b[i].s456);
    SG p = sg_product(ga, gb);
    prod[i] = (float8)(p.p, p.lam, p.mu, 0.0f);
    inner[i] = (float4)(sg_inner(ga, gb), 0.0f);
    SG w = sg_warp(ga, o[i].xyz);
    warp[i] = (float8)(w.p, w.lam, w.mu, 0.0f);
}

/* (θ_d, λ) → (f̂_h, f_h(π/2, λ), A(λ), 0). */
__kernel void t_fh(__global const float2 *x, __global float4 *out) {
    int i = get_global_id(0);
    out[i] = (float4)(fh_hat(x[i].x, x[i].y), fh_hemi(x[i].y), mean_resultant(x[i].y), 0.0f);
}

/* x → (sin x, cos x) of sincos_small, tan_small x, ½ erfc x, sinhc x, A(x), 0, 0. */
__kernel void t_fastmath(__global const float *x, __global float8 *out) {
    int i = get_global_id(0);
    float2 sc = sincos_small(x[i]);
    out[i] = (float8)(sc.x, sc.y, tan_small(x[i]), half_erfc(x[i]), sg_sinhc(x[i]),
                      mean_resultant(x[i]), 0.0f, 0.0f);
}

/* Cubemap chain lookups: bilinear level `lev` of a chain, trilinear MIP at lod, face/s/t. */
__kernel void t_cube(__global const float4 *data, __global const int *off, __global const int *res,
                     const int nlev, __global const float4 *dirs, __global const float *lods,
                     const int lev, __global float4 *bil, __global float4 *tri, __global float4 *fst) {
    int i = get_global_id(0);
    float3 d = dirs[i].xyz;
    bil[i] = (float4)(cube_bilinear(data, off[lev], res[lev], d), 0.0f);
    tri[i] = (float4)(cube_mip(data, off, res, nlev, d, lods[i]), 0.0f);
    float s, t;
    int f = cube_coords(d, &s, &t);
    fst[i] = (float4)((float)f, s, t, cube_lobe_lod(d, lods[i], 0.9f, res[0]));
}

/* Γ_L(p, λ) from a normalised pyramid. */
__kernel void t_gamma(__global const float4 *data, __global const int *off, __global const int *res,
                      __global const float *lam, const int nlev, const float log_ratio,
                      const float4 mean, __global const float4 *dirs, __global const float *lams,
                      __global float4 *out) {
    int i = get_global_id(0);
    out[i] = (float4)(gamma_lookup(data, off, res, lam, nlev, log_ratio, mean.xyz, dirs[i].xyz,
                                   lams[i]), 0.0f);
}

/* SSDF θ_d (unclamped decode) at local directions for one coefficient vector w (NV terms),
 * and the concentric-square coordinates of each direction. */
__kernel void t_ssdf(__global const float *basis, __global const float *mean, const int res,
                     __global const float *wv, const int has, __global const float4 *dirs,
                     __global float4 *out) {
    int i = get_global_id(0);
    ssdf_vec w[SSDF_NW];
    for (int j = 0; j < NV / SSDF_VW; ++j) w[j] = ssdf_vload(j, wv);
    float3 d = dirs[i].xyz;
    float2 uv = hemisphere_to_square(d);
    out[i] = (float4)(ssdf_theta(has, basis, mean, res, w, d), uv.x, uv.y, 0.0f);
}

/* M_o(i) and f_d(o, i) of material 0 (local frame). */
__kernel void t_brdf(__global const float *mats, __global const float *tables,
                     __global const float4 *o, __global const float4 *in, __global float4 *mo,
                     __global float4 *fd) {
    int i = get_global_id(0);
    mo[i] = (float4)(mf_M(mats, tables, mat3(mats, MAT_KS), o[i].xyz, in[i].xyz), 0.0f);
    fd[i] = (float4)(mf_diffuse(mats, mat3(mats, MAT_KD), o[i].xyz, in[i].xyz), 0.0f);
}

/* Texture lookups (shading.h): tex_filtered of texture k at OBJ uv with footprint duv. */
__kernel void t_tex(__global const float4 *texels, __global const int4 *texinfo,
                    __global const float4 *texaff, const int k, __global const float2 *uv,
                    __global const float4 *duv, __global float4 *out) {
    int i = get_global_id(0);
    out[i] = tex_filtered(texels, texinfo[k], texaff, k, uv[i], duv[i]);
}

/* A textured gltf_pbr material's kd, F0 and roughness (gltf_record.h gltf_filtered_params) at
 * OBJ uv with footprint duv, from its record mat. */
__kernel void t_gltf_params(__global const float *mat, __global const float4 *texels,
                            __global const int4 *texinfo, __global const float4 *texaff,
                            __global const float2 *uv, __global const float4 *duv,
                            __global float4 *kd, __global float4 *f0) {
    int i = get_global_id(0);
    float3 k, f;
    float r = gltf_filtered_params(mat, texels, texinfo, texaff, uv[i], duv[i], &k, &f);
    kd[i] = (float4)(k, r);
    f0[i] = (float4)(f, 0.0f);
}
