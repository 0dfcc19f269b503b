/* Part of the normal-map kernels' body (nm_shade_body.h, included inside each __kernel
 * function after the pixel's lobes, nm_lobes_body.h): the environment's diffuse and specular
 * terms and the lights, summed into out[gid] (nm_shade.h documents each). */

    float3 acc = (float3)(0.0f);
    if (!(flags & FLAG_NO_ENV_DIFFUSE)) {
#if NM_FILTER == NM_SH
        if (nsh >= 4 && n_env_sh > 0) {
            /* Σ_{l ≤ 2} Â_l γ_lm L_lm (eq 25 with the NDF's own coefficients), γ rotated to the
             * environment map's frame (unshadowed) */
            float gw[9];
            float gl[9];
            for (int k = 0; k < 9; ++k) gl[k] = k < nsh ? g[k] : 0.0f;
            for (int j = 0; j < n0l; ++j) {        /* level 0's taps as deltas */
                float y9[9];
                nm_sh_eval(to_local(ax[j].xyz, T, B, N), 2, y9);
                for (int k = 0; k < 9; ++k) gl[k] += lp[j].x * y9[k];
            }
            nm_sh_rotate9(gl, env_to_map(T), env_to_map(B), env_to_map(N), gw);  /* cubemap.h */
            const float ah[3] = {3.14159265f, 2.09439510f, 0.785398163f};
            float3 e = (float3)(0.0f);
            for (int k = 0; k < min(9, n_env_sh); ++k)
                e += ah[k == 0 ? 0 : (k < 4 ? 1 : 2)] * gw[k] * nm_env_sh[k].xyz;
            acc += kd * MF_INV_PI * fmax(e * env_scale, 0.0f);
        } else
#endif
        {
            /* the environment's diffuse part about the filtered normal (sg's SG-light sum) */
#if NM_FILTER != NM_VMF
            acc += nm_env_diffuse_at(m, kd, o, nbar, T, B, N, env_sg, n_env_sg, env_scale,
                                     &vis);
#elif defined(NM_PUB_SH_DIFFUSE)
            /* vmf_han07: eq 25 per lobe, level 0's taps (κ = ∞) included */
            float3 ed = (float3)(0.0f), edc = (float3)(0.0f);
            for (int j = 0; j < nlob; ++j) {
                float3 e = lp[j].x * nm_sh8_diffuse(nm_env_sh8, ax[j].xyz,
                                                    j < n0l ? 1e30f : nm_kappa_of(lrl[j]));
                ed += e;
                edc += lkd[j] * e;                  /* eq 22: each lobe in its colour */
            }
            acc += feat ? MF_INV_PI * fmax(edc * env_scale, 0.0f)
                        : kd * MF_INV_PI * fmax(ed * env_scale, 0.0f);
#else
            /* linear in the NDF (eq 5), as the lights' diffuse: level 0's taps at n̄ as unit
             * normals; the coarser part per lobe — the NM_DIFF_LOBES heaviest lobes j at their
             * own axes μ_j with weight α_j A(κ_j) (facets that turn away from part of the sky
             * see less of it than n̄ does), the rest of the mean, n̄₁ − Σ α_j A_j μ_j, at its
             * direction */
            float3 ed = (float3)(0.0f), rest = mean1, kd0 = kd;
            if (feat && n0l > 0) {          /* level 0's taps: their weighted mean colour */
                float w0 = 0.0f;
                kd0 = (float3)(0.0f);
                for (int j = 0; j < n0l; ++j) { kd0 += lp[j].x * lkd[j]; w0 += lp[j].x; }
                kd0 /= w0;
            }
            if (at0 && f < 1.0f)
                ed = (1.0f - f) * nm_env_diffuse_at(m, kd0, o, nbar, T, B, N, env_sg, n_env_sg,
                                                    env_scale, &vis);
            int used[NM_DIFF_LOBES];
            for (int u = 0; n_env_sg > 0 && u < NM_DIFF_LOBES; ++u) {
                int best = -1;
                float wbest = 0.0f;
                for (int j = n0l; j < nlob; ++j) {
                    int taken = 0;
                    for (int v = 0; v < u; ++v) taken |= used[v] == j;
                    float wj = lp[j].x * lrl[j];
                    if (!taken && wj > wbest) { wbest = wj; best = j; }
                }
                used[u] = best;
                if (best < 0) break;
                rest -= wbest * ax[best].xyz;
                ed += wbest * nm_env_diffuse_at(m, lkd[best], o, ax[best].xyz, T, B, N, env_sg,
                                                n_env_sg, env_scale, &vis);
            }
            float lrest = length(rest);
            if (n_env_sg > 0 && lrest > 1e-4f)
                ed += lrest * nm_env_diffuse_at(m, kd, o, rest / lrest, T, B, N, env_sg,
                                                n_env_sg, env_scale, &vis);
            acc += ed;
#endif
        }
    }
#if NM_FILTER == NM_VMF && defined(NM_PUB_SH_SPECULAR)
    /* vmf_han07: eq 26 per lobe, the whole map (its point set too) through L' */
    if (env_on && model != NM_LAMBERT) {
        float3 es = (float3)(0.0f);
        for (int j = 0; j < nlob; ++j) {
            float rj[NM_RHO_N];     /* a textured glTF lobe's ρ̂ at its own roughness */
            nm_rho_at(nm_data, bp, sv_ && model == NM_GLTF ? lp[j].y : -1.0f, rj);
            es += lp[j].x * nm_sh8_factor(m, lks[j], model, ax[j].xyz, o,
                                          model == NM_MERL ? lp[j].w / s : lp[j].w, tables)
                  * fmax(nm_sh8_specular(nm_env_sh8, rj, o, ax[j].xyz,
                                         j < n0l ? 1e30f : nm_kappa_of(lrl[j])), 0.0f);
        }
        acc += env_scale * es;
    }
#else
    if (env_on) {
        /* a textured glTF material's pixel record (gltf_pixel_record), re-set per lobe; any
         * other GGX or measured material's lobes convolve their NDF lobes with their vMF */
        __global float *rw_ = pxmat + gid * MAT_STRIDE;
        int conv_ = model == NM_MERL || ((model == NM_GGX || model == NM_GLTF) && !reset_);
        for (int j = 0; j < nlob; ++j) {
            /* GGX's bare lobes (level 0's taps, the plain MIP's) and vmf's filtered ones (D
             * amplitude −κ); the single-lobe methods' widened GGX lobes keep nm_spec_env's SG
             * of their α′ below */
            int bare = (model == NM_GGX || model == NM_GLTF) && ax[j].w == 1.0f && lp[j].w == s;
            int convj = conv_ && (model == NM_MERL || ax[j].w < 0.0f || bare);
            float kc_ = conv_ && ax[j].w < 0.0f ? -ax[j].w : 0.0f;
            if (reset_ || convj) {
                /* GGX and measured materials: the `sg` method's specular about the lobe's
                 * axis — the material's NDF lobes, each warped to three sub-lobes,
                 * energy-scaled — which holds GGX's tail where one SG of the peak-matched
                 * roughness loses it at grazing views. A filtered lobe convolves those NDF
                 * lobes with its vMF (ndf_lobe's κ) and is scaled by its normals'
                 * mean albedo at the view over the axis' (nm_lobe_albedo_ratio: the normals
                 * that see the view from below their horizon). A filtered lobe of a textured
                 * glTF material: the record set to the lobe's F0 and to the GGX whose peak is
                 * its D's (eq 21's a = lp.w), then back to the pixel's */
                if (sv_ && model == NM_GLTF) {
                    rw_[MAT_F0] = lks[j].x; rw_[MAT_F0 + 1] = lks[j].y;
                    rw_[MAT_F0 + 2] = lks[j].z;
                    if (reset_) gltf_record_alpha(mf_, rw_, lp[j].w, lp[j].w);
                }
                float4 q = quat_from_z(normalize(to_local(ax[j].xyz, T, B, N)));
                float4 qi = quat_conj(q);
                float3 op = lift(normalize(quat_rotate(qi, lift(to_local(o, T, B, N), 0.01f))),
                                 0.01f);
                float3 es[SHARP_CACHE];
                /* sg reads Fresnel from the record: a glTF lobe's ks (its F0) is the record's */
                float3 bks = model == NM_GLTF ? mat3(m, MAT_KS) : lks[j];
                float cr_ = convj && ax[j].w < 0.0f
                            ? nm_lobe_albedo_ratio(m, tables, dot(ax[j].xyz, o), -ax[j].w) : 1.0f;
                acc += cr_ * lp[j].x
                       * sg_lobes_specular(m, lobes, tables, bks, op, q, qi, T, B, N, x, &vis, 1,
                                           NM_EXACT_POINTS, 1, pyr, pyr_off, pyr_res, pyr_lam,
                                           pyr_n, pyr_log_ratio, env_mean, pyr_raw, raw_n,
                                           pyr_pts, NM_EXACT_POINTS ? 0 : n_pts, env_scale,
                                           lights, 0, es, kc_);
                if (sv_ && model == NM_GLTF) {
                    rw_[MAT_F0] = ks.x; rw_[MAT_F0 + 1] = ks.y; rw_[MAT_F0 + 2] = ks.z;
                    if (reset_) gltf_record_alpha(mf_, rw_, s, s);
                }
                continue;
            }
            acc += lp[j].x * nm_spec_env(m, lks[j], model, ax[j].xyz, o, lp[j].y, lp[j].z,
                                         lp[j].w, ax[j].w, T, B, N, &vis, pyr, pyr_off, pyr_res,
                                         pyr_lam, pyr_n, pyr_log_ratio, env_mean.xyz, pyr_pts,
                                         NM_EXACT_POINTS ? 0 : n_pts, pyr_raw, raw_n, env_scale);
        }
        /* the point set (a sun) as directional lights: every lobe's exact BRDF at each point,
         * shadowed at the point's own direction (nm_points) */
        if (NM_EXACT_POINTS)
            acc += env_scale * nm_points(m, lks, model, ax, lp, nlob, o, T, B, N, &vis,
                                         pyr_pts, n_pts, lobes, tables);
    }
#endif
#if NM_FILTER == NM_SH
    float yb[4 * NM_MAX_SH4];
    float rho[NM_RHO_N];        /* eq 12's ρ̂_l: a textured glTF material's at the pixel's α */
    nm_rho_at(nm_data, bp, sv_ && model == NM_GLTF ? s : -1.0f, rho);
#endif
    for (int k = 0; k < n_lights; ++k) {
        float4 a = lights[2 * k], b = lights[2 * k + 1];
        float3 i, E;
        if (a.w < 0.5f) {
            float3 d = a.xyz - x;
            float d2 = fmax(dot(d, d), 1e-12f);
            i = d * rsqrt(d2);
            E = b.xyz / d2;
        } else {
            i = normalize(a.xyz);
            E = b.xyz;
        }
        if (dot(i, N) <= 0.0f) continue;
        if (vis.has) E *= fh_hat(vis_theta(&vis, to_local(i, T, B, N)), NM_LIGHT_LAMBDA);
        float3 spec = (float3)(0.0f);
        float diff;
#if NM_FILTER == NM_VMF
        float3 dcol;                  /* with colour features: Σ lobes' kd × cosine */
#endif
#if NM_FILTER == NM_SH
        if (nsh > 0) {
            int ld = min(lsh, 2);
            nm_sh_eval(to_local(i, T, B, N), ld, yb);
            const float ah[3] = {3.14159265f, 2.09439510f, 0.785398163f};
            diff = 0.0f;
            for (int l = 0; l <= ld; ++l) {
                float bsum = 0.0f;
                for (int kk = l * l; kk < (l + 1) * (l + 1); ++kk) bsum += g[kk] * yb[kk];
                diff += ah[l] * bsum;
            }
            diff = fmax(diff, 0.0f);
            for (int j = 0; j < n0l; ++j) {            /* level 0's taps */
                diff += lp[j].x * fmax(dot(ax[j].xyz, i), 0.0f);
                if (model != NM_LAMBERT)
                    spec += lp[j].x * nm_spec(m, lks[j], model, ax[j].xyz, o, i, lp[j].y,
                                              lp[j].z, lp[j].w, ax[j].w, lobes, tables);
            }
            if (model != NM_LAMBERT) {
                float3 ol = nm_lift(o, nbar, 0.01f);
                float3 h = normalize(o + i);          /* o: lifted in the geometric frame */
                nm_sh_eval(to_local(h, T, B, N), lsh, yb);
                float reff = fmax(nm_sh_dot(g, yb, rho, lsh), 0.0f);               /* eq 12 */
                float ci = dot(nbar, i);
                if (ci > 0.0f) {
                    if (model == NM_BLINN) {
                        spec += ks * (reff * ci);
                    } else if (model == NM_MERL) {      /* ρ̂_l: its D*'s */
                        float3 hl;
                        spec += reff * nm_merl_m(m, tables, ks, nbar, ol, i, &hl);
                    } else {
                        float co = dot(nbar, ol);
                        float3 hb = normalize(ol + i);
                        float ch = dot(nbar, hb), oh = dot(ol, hb);
                        spec += nm_fres(m, ks, model, oh)
                               * (nm_mf_g(model, ci, co, ch, oh, s) * reff / co);
                    }
                }
            }
        } else
#endif
        {
#if NM_FILTER == NM_VMF
            diff = fmax(dot(mean1, i), 0.0f);
            for (int j = 0; j < n0l; ++j) diff += lp[j].x * fmax(dot(ax[j].xyz, i), 0.0f);
            if (feat) {
                /* eq 22: each lobe's cosine in its colour — the coarse lobes at their mean
                 * resultant α_j A(κ_j) μ_j, the rest of n̄₁ (what the lobes leave of the
                 * linear mean) in the plain MIP colour */
                float3 rest = mean1;
                dcol = (float3)(0.0f);
                for (int j = 0; j < nlob; ++j) {
                    float3 r = lp[j].x * (j < n0l ? 1.0f : lrl[j]) * ax[j].xyz;
                    if (j >= n0l) rest -= r;
                    dcol += lkd[j] * fmax(dot(r, i), 0.0f);
                }
                dcol += kd * fmax(dot(rest, i), 0.0f);
            }
#else
            diff = 0.0f;              /* one lobe at n̄, or box level 0's taps */
            for (int j = 0; j < nlob; ++j) diff += lp[j].x * fmax(dot(ax[j].xyz, i), 0.0f);
#endif
            for (int j = 0; j < nlob; ++j)
                spec += lp[j].x * nm_spec(m, lks[j], model, ax[j].xyz, o, i, lp[j].y, lp[j].z,
                                          lp[j].w, ax[j].w, lobes, tables);
        }
        float gd = 1.0f;
        if (model == NM_GLTF) {   /* glTF's diffuse under the F0 0.04 coat: o·h does not
                                   * depend on the normal, one factor for every lobe */
            float xh = 1.0f - clamp(dot(o, normalize(o + i)), 0.0f, 1.0f), x2 = xh * xh;
            gd = 0.96f * (1.0f - x2 * x2 * xh);
            diff *= gd;
        }
        float3 dk = kd * (diff * MF_INV_PI);
#if NM_FILTER == NM_VMF
        if (feat) dk = dcol * (gd * MF_INV_PI);
#endif
        acc += (dk + spec) * E;
    }
    out[gid] = (float4)(acc, 1.0f);
