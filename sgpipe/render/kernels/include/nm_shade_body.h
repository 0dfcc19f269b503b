/* Body of the normal-map kernels (included inside each __kernel function; NM_FILTER selects
 * the filter, nm_shade.h documents the shading). */
#if NM_FILTER == NM_VMF
#define NM_MAX_AX (NM_MAX_LOBES * NM_BOX_TEXELS + NM_MAX_L0)
#elif NM_FILTER == NM_SH
#define NM_MAX_AX (NM_MAX_L0 + 1)   /* level 0's taps, then the environment lobe */
#else
#define NM_MAX_AX NM_MAX_L0     /* box at level 0: one lobe per tap */
#endif
    NM_PIXEL_PROLOGUE;
    int obj = gobj[gid];
    int4 info = nm_info[obj];
    uv = nm_wrap_uv(uv, info.w);
    __global const float *bp = nm_brdf + NM_BRDF_STRIDE * obj;
    float s = bp[0];                       /* Blinn–Phong exponent or microfacet roughness */
    int model = (int)bp[2];
    if (sv_ && model == NM_GLTF) s = m[MAT_AV];   /* the pixel's filtered roughness */
    if (model == NM_GLTF) ks = mat3(m, MAT_F0);   /* glTF lobes carry F0 as ks (nm_fres) */
    /* a textured glTF material: its factor record, and whether the pixel's record can be re-set
     * to a lobe's own roughness (its roughness grid of NDF lobes; nm_terms_body.h) */
    __global const float *mf_ = mats + OBJ_MAT(ob) * MAT_STRIDE;
    int reset_ = model == NM_GLTF && sv_ && mf_[MAT_SVLOB] >= 0.0f;
    int env_on = bp[13] > 0.0f && !(flags & FLAG_NO_ENV_SPECULAR);
    float3 o = normalize(to_world(lift(to_local(gview[gid].xyz, T, B, N), 0.01f), T, B, N));

    /* MIP level from the footprint (clamped to the pyramid), trilinear weights. Isotropic
     * (max taps 1): the level of the longer UV derivative. Anisotropic (max taps N > 1): the
     * level of the shorter one, raised until N taps along the longer one span it; the taps'
     * α, α·r, mean normals and γ_lm are averaged (linear in the NDF, eq 24) before κ, μ. */
    int l0 = 0, l1 = 0, ntap = 1, nx = 1;
    float f = 0.0f;
    float2 uv0 = uv, du = (float2)(0.0f), dv = (float2)(0.0f);
    float4 tduv = gduv[gid];       /* one tap's share of the footprint (its colour's filter) */
    /* Box footprint (render.normalmap_footprint = box): the pixel's box filter (the
     * reference's) over the map, instead of trilinear's tent of twice the pixel. The box
     * has the footprint's extent along u and v, w_u = |(∂u/∂x, ∂u/∂y)|, w_v likewise (the
     * parallelogram's RMS width: its sides when axis-aligned); at the finest level where it
     * overlaps ≤ NM_BOX_TEXELS texels, each texel weighs its overlap (exact for the level's
     * piecewise-constant NDFs), and its lobes enter the mixture as they are — no blend of
     * unaligned lobes' α·r (eq 24) into one broad lobe between two texels' NDFs. Level 0 has
     * no lobes: a grid of bilinear-normal taps over the parallelogram, as the reference
     * samples it. */
#ifdef NM_PUB_TRILINEAR
    int box = 0;                        /* vmf_han07: Algorithm 2's trilinear MIP lookup */
#else
    int box = info.w && bp[NM_FOOT_SLOT] > 0.5f;
#endif
    int nbx = 0, bidx[NM_BOX_TEXELS];
    float bw[NM_BOX_TEXELS];
    if (info.w && box) {
        float4 duv = gduv[gid];
        float side = (float)nm_levels[info.x].y;
        float wu = length(duv.xz) * side, wv = length(duv.yw) * side;
        float cu = uv.x - floor(uv.x), cv = 1.0f - (uv.y - floor(uv.y));
        int lev = (int)clamp(floor(log2(fmax(fmin(wu, wv), 1e-18f))) - 1.0f, 0.0f,
                             (float)(info.y - 1));
        int iu[NM_BOX_TEXELS + 1], iv[NM_BOX_TEXELS + 1];
        float au[NM_BOX_TEXELS + 1], av[NM_BOX_TEXELS + 1];
        int nu = 0, nv = 0;
        for (; lev < info.y; ++lev) {
            int m = nm_levels[info.x + lev].y;
            float sc = exp2(-(float)lev);
            nu = nm_box_axis(cu * (float)m, wu * sc, m, NM_BOX_TEXELS, iu, au);
            nv = nu > NM_BOX_TEXELS ? 0
                 : nm_box_axis(cv * (float)m, wv * sc, m, NM_BOX_TEXELS / nu, iv, av);
            if (nu <= NM_BOX_TEXELS && nv <= NM_BOX_TEXELS / nu) break;
        }
        lev = min(lev, info.y - 1);
        /* an elongated footprint whose box needs a coarser level than trilinear's taps along
         * its major axis (at the minor axis' level) keeps those taps: a coarse box blurs the
         * minor axis over texels several times its width (grazing plane, 15°: vmf 25.9 dB
         * box-only against 27.8 dB with the taps) */
        float lx = length(duv.xy) * side, ly = length(duv.zw) * side;
        int max_taps = max((int)bp[1], 1);
        float len = max_taps > 1 ? fmax(fmin(lx, ly), fmax(lx, ly) / (float)max_taps)
                                 : fmax(lx, ly);
        if ((float)lev > floor(log2(fmax(len, 1.0f)))) box = 0;
        else l0 = l1 = info.x + lev;
        if (!box) {
        } else if (lev == 0) {          /* bilinear normals on an nx × ny grid over the parallelogram */
            nx = clamp((int)ceil(NM_L0_TAPS_PER_TEXEL * length(duv.xy) * side - 1e-3f), 1,
                       NM_BOX_L0_TAPS);
            int ny = clamp((int)ceil(NM_L0_TAPS_PER_TEXEL * length(duv.zw) * side - 1e-3f), 1,
                           NM_BOX_L0_TAPS);
            ntap = nx * ny;
            du = duv.xy / (float)nx;
            dv = duv.zw / (float)ny;
            tduv = (float4)(du, dv);
            uv0 = uv - 0.5f * (duv.xy + duv.zw) + 0.5f * (du + dv);
        } else {
            int m = nm_levels[l0].y;
            for (int b = 0; b < nv; ++b)
                for (int a = 0; a < nu; ++a) {
                    bidx[nbx] = iv[b] * m + iu[a];
                    bw[nbx] = av[b] * au[a];
                    ++nbx;
                }
        }
    }
    if (info.w && !box) {
        float4 duv = gduv[gid];
        float side = (float)nm_levels[info.x].y;
        float lx = length(duv.xy) * side, ly = length(duv.zw) * side;
        float major = fmax(lx, ly), minor = fmin(lx, ly);
        int max_taps = max((int)bp[1], 1);
        float len = max_taps > 1 ? fmax(minor, major / (float)max_taps) : major;
        float lod = clamp(log2(fmax(len, 1e-18f)), 0.0f, (float)(info.y - 1));
        if (max_taps > 1) {
            ntap = clamp((int)ceil(major / exp2(lod) - 1e-3f), 1, max_taps);
            du = lx >= ly ? duv.xy : duv.zw;
            uv0 = uv - du * (0.5f - 0.5f / (float)ntap);
            du /= (float)ntap;
            nx = ntap;
            tduv = lx >= ly ? (float4)(du, duv.zw) : (float4)(duv.xy, du);
        }
        l0 = (int)floor(lod);
        l1 = min(l0 + 1, info.y - 1);
        f = lod - (float)l0;
        l0 += info.x; l1 += info.x;
    }
    float3 mean_t = (float3)(0.0f, 0.0f, 1.0f);
    /* the texels' own mean-normal lengths (slot w) filtered as the normals are: what an engine
     * bakes per texel and samples like a roughness texture (toksvig, engine_bake, nm_sh) */
    float rbake = 1.0f;
#if NM_FILTER == NM_VMF
    float4 lob[NM_MAX_LOBES];
    int nl = min(info.z, NM_MAX_LOBES);
    for (int j = 0; j < nl; ++j) lob[j] = (float4)(0.0f);
    /* eq 22: each lobe's colour features α_j·(kd, ks) (two float4), filtered as α_j is; a
     * glTF material's (slot 2): α_j·(kd, F0, ln roughness), absolute (its factors applied) */
    int feat = info.w && bp[NM_FEAT_SLOT] > 0.5f;
    int featg = feat && bp[NM_FEAT_SLOT] > 1.5f;
    float4 fea[2 * NM_MAX_LOBES];
    for (int j = 0; j < 2 * nl; ++j) fea[j] = (float4)(0.0f);
    /* Where level 0 takes part (weight 1 − f), its texels are read as the renderer and the
     * reference read the map — the bilinearly interpolated normal, one sharp lobe per tap —
     * instead of eq 24's bilinear mix of the texels' delta lobes (which blurs every texel
     * boundary into a broad lobe: 33 dB vs 47 dB for the plain normal against the reference
     * at 16×16 supersampling). The J lobes then come from level 1 alone, weighted f.
     * vmf_han07 (NM_PUB_L0_BLEND): level 0's delta lobes through eq 24 as every level. */
#ifdef NM_PUB_L0_BLEND
    int at0 = 0;
#else
    int at0 = info.w && l0 == info.x;
#endif
    int n0c = min(ntap, NM_MAX_L0);
    float4 n0s[NM_MAX_L0], n0f[2 * NM_MAX_L0];    /* level 0's taps: normals, colour sums */
    for (int k = 0; k < n0c; ++k) n0s[k] = n0f[2 * k] = n0f[2 * k + 1] = (float4)(0.0f);
#endif
#if NM_FILTER != NM_VMF && NM_FILTER != NM_SH
    /* box at level 0: each tap's bilinear mean normal its own lobe (the method's formula at
     * that tap's length), as vmf's level-0 taps and the reference read the map */
    int at0 = box && l0 == info.x;
    int n0c = min(ntap, NM_MAX_L0);
    float4 n0s[NM_MAX_L0];
    float n0r[NM_MAX_L0];
    for (int k = 0; k < n0c; ++k) { n0s[k] = (float4)(0.0f); n0r[k] = 0.0f; }
#endif
#if NM_FILTER == NM_SH
    int nsh = info.w ? min((int)bp[3], 4 * NM_MAX_SH4) : 0;
    int k4 = (nsh + 3) / 4;
    int lsh = (int)(sqrt((float)nsh) + 0.5f) - 1;
#ifdef NM_PUB_SH_LSTAR
    /* §5: l* ≈ √(4s) of the material (the record's, normalmap_data.published_sh_order); the
     * render stage refuses a pyramid stored below it */
    lsh = min(lsh, (int)bp[NM_LSTAR_SLOT]);
#endif
    float g[4 * NM_MAX_SH4];
    for (int k = 0; k < 4 * k4; ++k) g[k] = 0.0f;
    /* Level 0 (weight 1 − f) read as vmf reads it, the bilinear normal, one sharp lobe of the
     * bare material per tap: its NDF is a delta, which l ≤ l* cannot hold (a Blinn–Phong
     * s = 60 lobe needs l ≈ 15). Eq 12's γ_lm then come from level 1 alone, weighted f.
     * nm_sh_han07 (NM_PUB_L0_BLEND): level 0's γ_lm = Y_lm(n) trilinear as every level's. */
#ifdef NM_PUB_L0_BLEND
    int at0 = 0;
#else
    int at0 = info.w && l0 == info.x;
#endif
    int n0c = min(ntap, NM_MAX_L0);
    float4 n0s[NM_MAX_L0];
    for (int k = 0; k < n0c; ++k) n0s[k] = (float4)(0.0f);
#endif
    if (nbx > 0) {                      /* box footprint above level 0: texels by overlap */
        int4 lv = nm_levels[l0];
        mean_t = (float3)(0.0f);
        rbake = 0.0f;
        for (int t = 0; t < nbx; ++t) {
            float4 mt = nm_data[lv.z + bidx[t]];
            mean_t += bw[t] * mt.xyz;
            rbake += bw[t] * mt.w;
#if NM_FILTER == NM_SH
            for (int c = 0; c < k4; ++c) {
                float4 v = bw[t] * nm_data[lv.w + bidx[t] * k4 + c];
                g[4 * c] += v.x; g[4 * c + 1] += v.y; g[4 * c + 2] += v.z; g[4 * c + 3] += v.w;
            }
#endif
        }
    } else if (info.w) {
        mean_t = (float3)(0.0f);
        rbake = 0.0f;
        for (int k = 0; k < ntap; ++k) {
            float2 uvk = nm_wrap_uv(uv0 + (float)(k % nx) * du + (float)(k / nx) * dv,
                                    info.w);
            float4 mk4 = nm_trilinear(nm_data, nm_levels, l0, l1, f, 1, 1, 0, uvk);
            float3 mk = mk4.xyz;
            mean_t += mk;
            rbake += mk4.w;
#if NM_FILTER != NM_VMF && NM_FILTER != NM_SH
            if (at0) {
                n0s[k % NM_MAX_L0] += (float4)(1.0f, mk);
                n0r[k % NM_MAX_L0] += mk4.w;
            }
#endif
#if NM_FILTER == NM_VMF
            if (at0) {
                int4 lv = nm_levels[l0];
                float4 nb = nm_bilinear(nm_data, lv.z, lv.y, 1, 0, uvk);
                n0s[k % NM_MAX_L0] += (float4)(1.0f, nb.xyz);
                /* the tap's colour: the colour textures themselves over the tap's share of
                 * the footprint, as the reference reads them beside the bilinear normal (any
                 * texture resolution; the features hold the map's grid) */
                if (featg) {    /* a glTF material's kd, F0, ln r over the tap's share */
                    float3 tkd, tf0;
                    float tr = gltf_filtered_params(mf_, texels, texinfo, texaff, uvk, tduv,
                                                    &tkd, &tf0);
                    n0f[2 * (k % NM_MAX_L0)] += (float4)(tkd, tf0.x);
                    n0f[2 * (k % NM_MAX_L0) + 1] += (float4)(tf0.y, tf0.z,
                        log(fmax(clamp(tr, 0.0f, 1.0f), NM_GLTF_MIN_R)), 0.0f);
                } else if (feat) {
                    float4 ck = kdt_ >= 0 ? tex_filtered(texels, texinfo[kdt_], texaff, kdt_,
                                                         uvk, tduv) : (float4)(1.0f);
                    float4 cs = kst_ >= 0 ? tex_filtered(texels, texinfo[kst_], texaff, kst_,
                                                         uvk, tduv) : (float4)(1.0f);
                    n0f[2 * (k % NM_MAX_L0)] += (float4)(ck.xyz, cs.x);
                    n0f[2 * (k % NM_MAX_L0) + 1] += (float4)(cs.y, cs.z, 0.0f, 0.0f);
                }
                if (f > 0.0f) {
                    int4 lw = nm_levels[l1];
                    for (int j = 0; j < nl; ++j) {
                        lob[j] += f * nm_bilinear(nm_data, lw.x, lw.y, info.z, j, uvk);
                        if (!feat) continue;
                        float4 c0, c1;
                        nm_feat_trilinear(nm_data, nm_levels, l1, l1, 0.0f, info.z, j, uvk,
                                          &c0, &c1);
                        fea[2 * j] += f * c0;
                        fea[2 * j + 1] += f * c1;
                    }
                }
            } else {
                for (int j = 0; j < nl; ++j) {
                    lob[j] += nm_trilinear(nm_data, nm_levels, l0, l1, f, 0, info.z, j, uvk);
                    if (!feat) continue;
                    float4 c0, c1;
                    nm_feat_trilinear(nm_data, nm_levels, l0, l1, f, info.z, j, uvk, &c0, &c1);
                    fea[2 * j] += c0;
                    fea[2 * j + 1] += c1;
                }
            }
#endif
#if NM_FILTER == NM_SH
            if (at0) {
                int4 lv = nm_levels[l0];
                n0s[k % NM_MAX_L0] += (float4)(1.0f, nm_bilinear(nm_data, lv.z, lv.y, 1, 0,
                                                                 uvk).xyz);
            }
            if (!at0 || f > 0.0f) {
                for (int c = 0; c < k4; ++c) {
                    float4 v = at0 ? f * nm_bilinear(nm_data, nm_levels[l1].w, nm_levels[l1].y,
                                                     k4, c, uvk)
                                   : nm_trilinear(nm_data, nm_levels, l0, l1, f, 2, k4, c, uvk);
                    g[4 * c] += v.x; g[4 * c + 1] += v.y; g[4 * c + 2] += v.z;
                    g[4 * c + 3] += v.w;
                }
            }
#endif
        }
        mean_t /= (float)ntap;
        rbake /= (float)ntap;
#if NM_FILTER == NM_VMF
        for (int j = 0; j < nl; ++j) lob[j] /= (float)ntap;
        for (int j = 0; j < 2 * nl; ++j) fea[j] /= (float)ntap;
#endif
#if NM_FILTER == NM_SH
        for (int k = 0; k < nsh; ++k) g[k] /= (float)ntap;
#endif
    }
    float3 mean = to_world(mean_t, T, B, N);
    float rl = length(mean);
    float3 nbar = rl > 0.0f ? mean / rl : N;
    /* r of the single-lobe formulas: engine_bake and nm_sh's environment lobe read the baked
     * per-texel length, as an engine's stored roughness texture holds it; toksvig the length
     * of the filtered mean (Toksvig 2005, per fetch: it also counts the spread between the
     * texels it blends), except at level 0's box taps, which are normalised (r = 1, below) */
#if NM_FILTER == NM_TOKSVIG
    float rlobe = rl;
#else
    float rlobe = fmin(rbake, 1.0f);
#endif

#include "nm_lobes_body.h"
#include "nm_terms_body.h"
