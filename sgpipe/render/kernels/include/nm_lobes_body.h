/* Part of the normal-map kernels' body (nm_shade_body.h, included inside each __kernel
 * function after the footprint's fetches): the pixel's specular lobes ax / lp and their
 * count nlob, per filter (nm_shade.h documents each). */
    /* The pixel's specular lobes: axis (world), weight, Blinn–Phong exponent e with its
     * normalisation, microfacet roughness a with its D amplitude (nm_shade.h). */
    float4 ax[NM_MAX_AX];         /* axis (world), D amplitude (microfacet) */
#if NM_FILTER == NM_VMF
    float lrl[NM_MAX_AX];         /* vmf: each lobe's mean resultant length A(κ) */
#endif
    float4 lp[NM_MAX_AX];         /* (weight, e, norm, a) */
    float3 lkd[NM_MAX_AX], lks[NM_MAX_AX];   /* each lobe's kd, ks (eq 22; else the pixel's) */
    int nlob = 0;
    float bnorm = 0.25f * (s + 2.0f) / (s + 1.0f) * NM_INV_2PI;   /* × (s′ + 1): eq 20 */
#if NM_FILTER == NM_VMF
    /* Diffuse: level 0's part (weight 1 − f) at its unit bilinear normals — the first n0l
     * lobes, as the reference and normals_mip read the map: the plain bilinear mean is shorter
     * (0.8 at the grooves' kinks) and darkened vmf against both — and the coarser part
     * f·n̄₁ (linear in the NDF, eq 5) as the plain mean. */
    int n0l = 0;
    float3 mean1 = mean;
    if (info.w && at0) {
        float3 s0 = (float3)(0.0f);
        for (int k = 0; k < n0c; ++k) s0 += n0s[k].yzw;
        mean1 = to_world(mean_t - (1.0f - f) * s0 / (float)ntap, T, B, N);
    }
    if (!info.w) {
        ax[0] = (float4)(N, 1.0f); lp[0] = (float4)(1.0f, s, bnorm * (s + 1.0f), s); nlob = 1;
        lrl[0] = 1.0f;
        lkd[0] = kd; lks[0] = ks;
    } else {
        for (int k = 0; at0 && k < n0c; ++k) {               /* level 0: bilinear normals */
            float3 nk = to_world(n0s[k].yzw, T, B, N);
            float ln = length(nk);
            if (n0s[k].x <= 0.0f || ln <= 0.0f) continue;
            float wt = (1.0f - f) * (n0s[k].x / (float)ntap);
            float3 ckd = kd, cks = ks;
            float sk = s;                   /* the tap's roughness (a glTF material's own) */
            if (feat) {
                float4 c0 = n0f[2 * k] / n0s[k].x, c1 = n0f[2 * k + 1] / n0s[k].x;
                ckd = c0.xyz;               /* the textures' values (× kd, ks below; glTF's */
                cks = (float3)(c0.w, c1.x, c1.y);                   /* kd, F0 themselves) */
                if (featg && reset_) {
                    float rk = clamp(exp(c1.z), NM_GLTF_MIN_R, 1.0f);
                    sk = rk * rk;
                }
            }
            float4 tpar = (float4)(1.0f, sk, bnorm * (sk + 1.0f), sk);
            if (nm_merge_tap(ax, lp, lkd, lks, 0, nlob, nk / ln, wt, tpar, ckd, cks)) continue;
            ax[nlob] = (float4)(nk / ln, 1.0f);
            lp[nlob] = (float4)(wt, tpar.yzw);
            lkd[nlob] = ckd; lks[nlob] = cks;
            ++nlob;
        }
        n0l = nlob;
        int lvx = nm_levels[l0].x;
        for (int j = 0; j < (nbx > 0 ? nbx * nl : nl); ++j) {
            /* box: texel j / nl's lobe j % nl, weighted by its overlap */
            float4 t = nbx > 0 ? bw[j / nl] * nm_data[lvx + bidx[j / nl] * info.z + j % nl]
                               : lob[j];
            if (t.x <= 0.0f) continue;
            float3 r = t.yzw / t.x;
            float lr = length(r);
            if (lr <= 0.0f) continue;
            float kappa = nm_kappa_of(lr);
            float3 ckd = kd, cks = ks;
            float sj = s;                   /* the lobe's material roughness (or exponent) */
            if (feat) {                     /* eq 22: the lobe's own features T(α·f)/T(α) */
                float4 c0 = fea[2 * j], c1 = fea[2 * j + 1];
                if (nbx > 0) {
                    int4 lv = nm_levels[l0];
                    int fo = lv.x + lv.y * lv.y * info.z + 2 * (bidx[j / nl] * info.z + j % nl);
                    c0 = bw[j / nl] * nm_data[fo];
                    c1 = bw[j / nl] * nm_data[fo + 1];
                }
                ckd = c0.xyz / t.x;
                cks = (float3)(c0.w, c1.x, c1.y) / t.x;
                if (featg) {                /* glTF: kd, F0 and the lobe's mean ln roughness */
                    float rj = clamp(exp(c1.z / t.x), NM_GLTF_MIN_R, 1.0f);
                    sj = rj * rj;
                }
            }
            float sp = kappa > 1e20f ? sj : kappa * sj / (kappa + sj);       /* eq 20 */
            float a2 = nm_convolved_a2(model, sj, kappa);                      /* eq 21 */
            float3 mu = normalize(to_world(r / lr, T, B, N));
            /* D amplitude (Cook–Torrance); GGX: −κ, the lobe's D convolved (nm_mf_d), the
             * lobe's roughness before the convolution in the exponent's slot */
            int ggx = model == NM_GGX || model == NM_GLTF || model == NM_MERL;
            float da = ggx ? -kappa : sj * sj / a2;
            float4 par = (float4)(da, ggx ? sj : sp, bnorm * (sp + 1.0f), sqrt(a2));
            /* the box's texels repeat on a periodic map: their equal lobes shade once */
            if (nm_merge_tap(ax, lp, lkd, lks, n0l, nlob, mu, t.x, par, ckd, cks)) continue;
            lrl[nlob] = fmin(lr, 1.0f);
            ax[nlob] = (float4)(mu, par.x);
            lp[nlob] = (float4)(t.x, par.yzw);
            lkd[nlob] = ckd; lks[nlob] = cks;
            ++nlob;
        }
    }
    /* eq 22: the material's kd, ks × the features (glTF's are absolute) */
    for (int j = 0; feat && !featg && j < nlob; ++j) {
        lkd[j] *= mat3(m, MAT_KD);
        lks[j] *= mat3(m, MAT_KS);
    }
#elif NM_FILTER == NM_SH
    /* level 0's taps (lobes 0 … n0l − 1: the bare material at the bilinear normal), then for
     * the environment's specular the engine_bake lobe about n̄ (weight f, or 1 above level 0) */
    int n0l = 0;
    for (int k = 0; at0 && k < n0c; ++k) {
        float3 nk = to_world(n0s[k].yzw, T, B, N);
        float ln = length(nk), amp;
        if (n0s[k].x <= 0.0f || ln <= 0.0f) continue;
        float3 q = nm_single_lobe(NM_MIP, info.w, 1.0f, s, bnorm, &amp);
        ax[nlob] = (float4)(nk / ln, amp);
        lp[nlob] = (float4)((1.0f - f) * (n0s[k].x / (float)ntap), q.x, q.y, q.z);
        lkd[nlob] = kd; lks[nlob] = ks;
        ++nlob;
    }
    n0l = nlob;
    if (!at0 || f > 0.0f) {
        float amp;
        float3 q = nm_single_lobe(NM_SH, info.w, rlobe, s, bnorm, &amp);
        if (model == NM_MERL) amp = -nm_merl_kappa(NM_SH, info.w, rlobe);
        ax[nlob] = (float4)(nbar, amp);
        lp[nlob] = (float4)(at0 ? f : 1.0f, q.x, q.y, q.z);
        lkd[nlob] = kd; lks[nlob] = ks;
        ++nlob;
    }
#else
    {
        int nsrc = at0 ? n0c : 1;
        for (int k = 0; k < nsrc; ++k) {
            float3 ak = nbar;
            float rk = rlobe, wk = 1.0f, amp;
            if (at0) {                                /* box, level 0: the tap's lobe */
                if (n0s[k].x <= 0.0f) continue;
                float3 mk = to_world(n0s[k].yzw / n0s[k].x, T, B, N);
                rk = length(mk);
                if (rk <= 0.0f) continue;
                ak = mk / rk;
                rk = fmin(n0r[k] / n0s[k].x, 1.0f);    /* level 0's baked length, 1 */
                wk = n0s[k].x / (float)ntap;
            }
            float3 q = nm_single_lobe(NM_FILTER, info.w, rk, s, bnorm, &amp);
            if (model == NM_MERL) amp = -nm_merl_kappa(NM_FILTER, info.w, rk);
            if (at0 && nm_merge_tap(ax, lp, lkd, lks, 0, nlob, ak, wk, (float4)(amp, q), kd,
                                    ks)) continue;
            ax[nlob] = (float4)(ak, amp);
            lp[nlob] = (float4)(wk, q.x, q.y, q.z);
            lkd[nlob] = kd; lks[nlob] = ks;
            ++nlob;
        }
    }
#endif
