/* Measured (MERL) materials in the normal-map kernels (Han07 eq 14 through the material's
 * fitted NDF lobes, nm_shade.h NM_MERL): the lobes' D* convolved with a lobe's vMF, the BRDF's
 * other factors M_o at the lobe's axis, the single-lobe methods' κ. Included by nm_shade.h
 * after nm_kappa_of. */
#ifndef SGPIPE_NM_MERL_H
#define SGPIPE_NM_MERL_H

/* κ of the single-lobe methods' vMF for a measured material's lobes (nm_single_lobe's rules
 * in SG form): toksvig 2/κ = 2(1 − r)/r (its α′² = α² + 2(1 − r)/r), engine_bake and nm_sh
 * Banerjee's κ(r), normals_mip and an unmapped object none (1e30). */
inline float nm_merl_kappa(int filter, int has_map, float rl) {
    if (!has_map || filter == NM_MIP || rl >= 1.0f) return 1e30f;
    if (filter == NM_TOKSVIG) return rl / fmax(1.0f - rl, 1e-6f);
    return nm_kappa_of(rl);
}

/* A measured material's D* at the unit half vector hl of a lobe's frame (z its axis): the
 * record's NDF SG lobes (the `sg` method's representation of it), each convolved with
 * vMF(κ = −amp; amp ≥ 0: none) by ndf_lobe: λ′ = λκ/(λ + κ), μ′ = μλ′/λ (Han07 eq 14 / 21
 * for a sum of SGs: a vMF convolved with an SG is the SG of the same mass and that λ′). */
inline float nm_merl_d(__global const float *m, __global const float4 *lobes, float3 hl,
                       float amp) {
    float kc = amp < 0.0f && -amp < 1e20f ? -amp : 0.0f, d = 0.0f;   /* 1e30: none */
    int nsg = min((int)m[MAT_NLOBES], MAX_NDF_LOBES);
    for (int k = 0; k < nsg; ++k) {
        float4 L0, L1;
        ndf_lobe(lobes, m, k, kc, &L0, &L1);
        d += L1.x * exp(L0.w * (dot(normalize(L0.xyz), hl) - 1.0f));
    }
    return d;
}

/* A measured material's BRDF × cosine without D about the unit axis n: M_o (Wang09 eq 13:
 * ks, g_scale, its tabulated shadowing, Fresnel at o·h, 1/π(n·i)(n·o)) × (n·i), with o and i
 * in a frame of n (isotropic: any tangent), and the half vector *hl in it. */
inline float3 nm_merl_m(__global const float *m, __global const float *tables, float3 ks,
                        float3 n, float3 o, float3 i, float3 *hl) {
    float3 t = normalize(cross(n, fabs(n.x) < 0.9f ? (float3)(1.0f, 0.0f, 0.0f)
                                                   : (float3)(0.0f, 1.0f, 0.0f)));
    float3 b = cross(n, t);
    float3 ol = (float3)(dot(o, t), dot(o, b), dot(o, n));
    float3 il = (float3)(dot(i, t), dot(i, b), dot(i, n));
    *hl = normalize(ol + il);
    return mf_M(m, tables, ks, ol, il) * il.z;
}

#endif
