/* A textured gltf_pbr material's per-pixel record (Wang09 §4.1: the model's parameters
 * textured, the reflectance built per pixel): included by shading.h after tex_filtered. */
#ifndef SGPIPE_GLTF_RECORD_H
#define SGPIPE_GLTF_RECORD_H

/* The roughness part of a textured gltf_pbr record r (gltf_pixel_record) from the material's
 * factor record m: α_t = au, α = av, g_scale and the NDF lobes interpolated from the roughness
 * grid at α (LOBE0, NLOBES, SVFRAC). The normal-map kernels re-set it per filtered lobe. */
inline void gltf_record_alpha(__global const float *m, __global float *r, float au, float av) {
    r[MAT_AU] = au; r[MAT_AV] = av;
    r[MAT_GSCALE] = 1.0f / (4.0f * au * av);
    r[MAT_SVFRAC] = 0.0f;
    if (m[MAT_SVLOB] >= 0.0f) {
        int ne = (int)m[MAT_SVN];
        float g = (log(av) - log(m[MAT_SVA0])) / (log(m[MAT_SVA1]) - log(m[MAT_SVA0]))
                  * (float)(ne - 1);
        g = clamp(g, 0.0f, (float)(ne - 1));
        int i0 = min((int)floor(g), ne - 2);
        int step = (int)m[MAT_SVSTEP];
        r[MAT_LOBE0] = m[MAT_SVLOB] + (float)(i0 * step);
        r[MAT_NLOBES] = (float)(step - 1);
        r[MAT_SVFRAC] = g - (float)i0;
    }
}

/* A point (s, t) of a textured gltf_pbr material's linear-parameter textures ia = (kd, ln r),
 * ib = (F0, m) per texel (MAT_SVLIN, level 0) read as the reference reads the glTF textures
 * (GltfSurface.params): each of the 2 × 2 texels' base colour c, metallic m and roughness r
 * mixed bilinearly (r as stored, floored at the BRDF's 0.06), then kd = (1 − m)c, F0 =
 * lerp(0.04, c, m) of the mix (*kd, *f0); ln r returned. The bilinear mix of kd and F0 themselves differs where metalness changes: half-way
 * between a dielectric texel of colour c₁ and a metal one of c₂, m = ½ and kd = (c₁ + c₂)/4,
 * where the mix of their kd is c₁/2 (a metal's kd is 0). */
inline float gltf_point_params(__global const float4 *texels, int4 ia, int4 ib, float2 st,
                               float3 *kd, float3 *f0) {
    int4 q;
    float2 f = tex_corners(ia, ia.y, ia.z, st, &q);
    int w = ia.y;
    int idx[4] = {q.z * w + q.x, q.z * w + q.y, q.w * w + q.x, q.w * w + q.y};
    float wt[4] = {(1.0f - f.x) * (1.0f - f.y), f.x * (1.0f - f.y), (1.0f - f.x) * f.y,
                   f.x * f.y};
    float3 c = (float3)(0.0f);
    float metal = 0.0f, r = 0.0f;
    for (int k = 0; k < 4; ++k) {
        float4 a = texels[ia.x + idx[k]], b = texels[ib.x + idx[k]];
        /* c from whichever of kd = (1 − m)c and F0 − 0.04(1 − m) = mc divides by more */
        float3 ck = b.w <= 0.5f ? a.xyz / (1.0f - b.w)
                                : (b.xyz - 0.04f * (1.0f - b.w)) / b.w;
        c += wt[k] * ck;
        metal += wt[k] * b.w;
        r += wt[k] * exp(a.w);
    }
    metal = clamp(metal, 0.0f, 1.0f);
    *kd = (1.0f - metal) * c;
    *f0 = mix((float3)(0.04f), c, metal);
    return log(r);
}

/* A textured gltf_pbr material's kd, F0 (*kd, *f0) and roughness (returned, unclamped) over
 * the footprint duv about uv (gltf_pixel_record's filtering) from its factor record m. */
inline float gltf_filtered_params(__global const float *m, __global const float4 *texels,
                                  __global const int4 *texinfo, __global const float4 *texaff,
                                  float2 uv, float4 duv, float3 *kd_out, float3 *f0_out) {
    float3 c = mat3(m, MAT_BASE);
    float metal = m[MAT_METAL], rough = m[MAT_ROUGH];
    int bt = (int)m[MAT_BCTEX], mt = (int)m[MAT_MRTEX];
    float3 kd, f0;
    float2 st, dx, dy;
    int nx, ny;
    if (m[MAT_SVLIN] > 0.5f
        && tex_grid(texinfo[bt], texaff, bt, uv, duv, &st, &dx, &dy, &nx, &ny) == 0) {
        /* the finest level: each tap the product form at its point, as the reference reads */
        float lr = 0.0f;
        kd = f0 = (float3)(0.0f);
        for (int j = 0; j < ny; ++j)
            for (int i = 0; i < nx; ++i) {
                float3 k1, f1;
                lr += gltf_point_params(texels, texinfo[bt], texinfo[mt],
                                        tex_tap(st, dx, dy, i, j, nx, ny), &k1, &f1);
                kd += k1;
                f0 += f1;
            }
        kd /= (float)(nx * ny);
        f0 /= (float)(nx * ny);
        rough = exp(lr / (float)(nx * ny));     /* the taps' geometric mean, as the MIPs' */
    } else if (m[MAT_SVLIN] > 0.5f) {  /* (kd, ln r) and (F0, m) per texel, factors applied */
        float4 a = tex_filtered(texels, texinfo[bt], texaff, bt, uv, duv);
        kd = a.xyz;
        rough = exp(a.w);              /* the footprint's geometric mean roughness */
        f0 = tex_filtered(texels, texinfo[mt], texaff, mt, uv, duv).xyz;
    } else {
        if (bt >= 0) c *= tex_filtered(texels, texinfo[bt], texaff, bt, uv, duv).xyz;
        if (mt >= 0) {
            float4 t = tex_filtered(texels, texinfo[mt], texaff, mt, uv, duv);
            rough *= t.y;
            metal *= t.z;
        }
        metal = clamp(metal, 0.0f, 1.0f);
        kd = (1.0f - metal) * c;
        f0 = mix((float3)(0.04f), c, metal);
    }
    *kd_out = kd;
    *f0_out = f0;
    return rough;
}

/* A textured gltf_pbr material's record for one pixel (Wang09 §4.1: the model's parameters
 * textured, the reflectance built per pixel), written into the pixel's scratch record r:
 * kd = (1 − m) c, Schlick F0 = lerp(0.04, c, m) and roughness filtered over the footprint (ln r) —
 * read as such (MAT_SVLIN: textures of these per texel, render.setup.linear_parameters) or
 * formed from the filtered base colour c and metallic m (factor × texel) — then what the
 * uniform material's packer derives (brdf.models.gltf_pbr): α = max(roughness, 0.06)²,
 * α_t = lerp(α, 1, s²), g_scale = 1/(4 α_t α); the NDF lobes interpolated from the roughness
 * grid (ndf_sg_rough.npz: LOBE0 = the lower entry, SVFRAC the upper one's weight; ndf_lobe)
 * and SV = 1: the exact D analytic at the pixel's α (ndf_exact) instead of the material's
 * table. */
inline void gltf_pixel_record(__global const float *m, __global float *r,
                              __global const float4 *texels, __global const int4 *texinfo,
                              __global const float4 *texaff, float2 uv, float4 duv,
                              float aniso_scale) {
    for (int k = 0; k < MAT_STRIDE; ++k) r[k] = m[k];
    float3 kd, f0;
    float rough = gltf_filtered_params(m, texels, texinfo, texaff, uv, duv, &kd, &f0);
    float rr = fmax(clamp(rough, 0.0f, 1.0f), 0.06f);
    float av = rr * rr, s = clamp(m[MAT_ANISO] * aniso_scale, 0.0f, 1.0f);
    float au = av + (1.0f - av) * s * s;
    r[MAT_KD] = kd.x; r[MAT_KD + 1] = kd.y; r[MAT_KD + 2] = kd.z;
    r[MAT_F0] = f0.x; r[MAT_F0 + 1] = f0.y; r[MAT_F0 + 2] = f0.z;
    r[MAT_KDTEX] = -1.0f; r[MAT_KSTEX] = -1.0f;
    r[MAT_DIFFUSE] = 3.0f;     /* glTF's (the factors' record says none where metallic = 1) */
    r[MAT_SV] = 1.0f;
    gltf_record_alpha(m, r, au, av);
}

#endif
