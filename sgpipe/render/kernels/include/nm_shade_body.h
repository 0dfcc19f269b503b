/* Body of the vmf / normals_mip / toksvig kernels (included inside each __kernel function;
 * NM_FILTER selects the filter, nm_shade.h documents the shading). */
    SHADE_PIXEL_PROLOGUE;
    int obj = gobj[gid];
    int4 info = nm_info[obj];
    float s = nm_brdf[4 * obj];
    float3 o = normalize(to_world(lift(to_local(gview[gid].xyz, T, B, N), 0.01f), T, B, N));

    /* MIP level from the footprint (clamped to the pyramid), trilinear weights. Isotropic
     * (max taps 1): the level of the longer UV derivative. Anisotropic (max taps N > 1): the
     * level of the shorter one, raised until N taps along the longer one span it; the taps'
     * α, α·r and mean normals are averaged (linear in the NDF, eq 24) before κ, μ. */
    int l0 = 0, l1 = 0, ntap = 1;
    float f = 0.0f;
    float2 uv0 = px.uv, du = (float2)(0.0f);
    if (info.w) {
        float4 duv = gduv[gid];
        float side = (float)nm_levels[info.x].y;
        float lx = length(duv.xy) * side, ly = length(duv.zw) * side;
        float major = fmax(lx, ly), minor = fmin(lx, ly);
        int max_taps = max((int)nm_brdf[4 * obj + 1], 1);
        float len = max_taps > 1 ? fmax(minor, major / (float)max_taps) : major;
        float lod = clamp(log2(fmax(len, 1e-18f)), 0.0f, (float)(info.y - 1));
        if (max_taps > 1) {
            ntap = clamp((int)ceil(major / exp2(lod) - 1e-3f), 1, max_taps);
            du = lx >= ly ? duv.xy : duv.zw;
            uv0 = px.uv - du * (0.5f - 0.5f / (float)ntap);
            du /= (float)ntap;
        }
        l0 = (int)floor(lod);
        l1 = min(l0 + 1, info.y - 1);
        f = lod - (float)l0;
        l0 += info.x; l1 += info.x;
    }
    float4 lob[NM_MAX_LOBES];
    int nl = min(info.z, NM_MAX_LOBES);
    for (int j = 0; j < nl; ++j) lob[j] = (float4)(0.0f);
    float3 mean_t = (float3)(0.0f, 0.0f, 1.0f);
#if NM_FILTER == NM_VMF
    /* Where level 0 takes part (weight 1 − f), its texels are read as the renderer and the
     * reference read the map — the bilinearly interpolated normal, one sharp lobe per tap —
     * instead of eq 24's bilinear mix of the texels' delta lobes (which blurs every texel
     * boundary into a broad lobe: 33 dB vs 47 dB for the plain normal against the reference
     * at 16×16 supersampling). The J lobes then come from level 1 alone, weighted f. */
    int at0 = info.w && l0 == info.x;
    int n0c = min(ntap, NM_MAX_L0);
    float4 n0s[NM_MAX_L0];
    for (int k = 0; k < n0c; ++k) n0s[k] = (float4)(0.0f);
#endif
    if (info.w) {
        mean_t = (float3)(0.0f);
        for (int k = 0; k < ntap; ++k) {
            float2 uvk = uv0 + (float)k * du;
            mean_t += nm_trilinear(nm_data, nm_levels, l0, l1, f, 0, 0, 1, uvk).xyz;
#if NM_FILTER == NM_VMF
            if (at0) {
                int4 lv = nm_levels[l0];
                float4 nb = nm_bilinear(nm_data, lv.z, lv.y, 1, 0, uvk);
                n0s[k % NM_MAX_L0] += (float4)(1.0f, nb.xyz);
                if (f > 0.0f) {
                    int4 lw = nm_levels[l1];
                    for (int j = 0; j < nl; ++j)
                        lob[j] += f * nm_bilinear(nm_data, lw.x, lw.y, info.z, j, uvk);
                }
            } else {
                for (int j = 0; j < nl; ++j)
                    lob[j] += nm_trilinear(nm_data, nm_levels, l0, l1, f, info.z, j, 0, uvk);
            }
#endif
        }
        mean_t /= (float)ntap;
        for (int j = 0; j < nl; ++j) lob[j] /= (float)ntap;
    }
    float3 mean = to_world(mean_t, T, B, N);
    float rl = length(mean);
    float3 nbar = rl > 0.0f ? mean / rl : N;

    float3 acc = (float3)(0.0f);
    if (!(flags & FLAG_NO_ENV_DIFFUSE)) {
        /* the environment's diffuse part about the filtered normal (sg's SG-light sum) */
        q = quat_from_z(normalize(to_local(nbar, T, B, N)));
        qi = quat_conj(q);
        op = lift(normalize(quat_rotate(qi, lift(to_local(o, T, B, N), 0.01f))), 0.01f);
        acc += diffuse_env_sg(m, kd, op, q, qi, T, B, N, env_sg, n_env_sg, env_scale, &vis);
    }
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
        float spec = 0.0f, diff;
#if NM_FILTER == NM_VMF
        diff = fmax(dot(mean, i), 0.0f);
        if (!info.w) {
            spec = nm_blinn(N, o, i, s, (s + 2.0f) * 0.125f * MF_INV_PI);
        } else {
            for (int k = 0; at0 && k < n0c; ++k) {            /* level 0: bilinear normals */
                float3 nk = to_world(n0s[k].yzw, T, B, N);
                float ln = length(nk);
                if (n0s[k].x <= 0.0f || ln <= 0.0f) continue;
                spec += (1.0f - f) * (n0s[k].x / (float)ntap)
                        * nm_blinn(nk / ln, o, i, s, (s + 2.0f) * 0.125f * MF_INV_PI);
            }
            for (int j = 0; j < nl; ++j) {
                float4 t = lob[j];
                if (t.x <= 0.0f) continue;
                float3 r = t.yzw / t.x;
                float lr = length(r);
                if (lr <= 0.0f) continue;
                float kappa = lr >= 1.0f ? 1e30f : (3.0f * lr - lr * lr * lr) / (1.0f - lr * lr);
                float sp = kappa * s / (kappa + s);                         /* eq 20 */
                float3 mu = normalize(to_world(r / lr, T, B, N));
                float norm = 0.25f * (s + 2.0f) / (s + 1.0f) * (sp + 1.0f) * NM_INV_2PI;
                spec += t.x * nm_blinn(mu, o, i, sp, norm);
            }
        }
#else
        float e = s;
#if NM_FILTER == NM_TOKSVIG
        if (info.w) e = s * rl / (rl + s * (1.0f - rl));
#endif
        diff = fmax(dot(nbar, i), 0.0f);
        spec = nm_blinn(nbar, o, i, e, (e + 2.0f) * 0.125f * MF_INV_PI);
#endif
        acc += (px.kd * (diff * MF_INV_PI) + px.ks * spec) * E;
    }
    out[gid] = (float4)(acc, 1.0f);
