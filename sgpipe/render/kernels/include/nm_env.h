/* The normal-map kernels' environment specular (Han07 eq 24–26 with an SG in place of SH), one
 * filtered lobe at a time: its D about the lobe axis n as an SG in h, warped to i-space about
 * the reflected view, times the BRDF's other factors, through the `sg` method's accurate Γ_L
 * pyramid and the point set's Gaussians. Included by nm_shade.h (needs nm_lift, nm_mf_g).
 *
 * The warp keeps its anisotropy (NM_SUBLOBES = 3, the `sg` method's spec_warp): seen from o at
 * c = o·n, the h-lobe's offsets across the plane of incidence move i by 2c per radian and those
 * in it by 2, so the i-lobe has sharpness λ/(4c²) across and λ/4 along the plane; three
 * isotropic sub-lobes of the across sharpness at 0, ±√3·σ_s along the plane (σ_s² = 4(1 − c²)/λ,
 * offset ≤ 0.5 rad, weights 2/3, 1/6, 1/6) carry the same variance and integral. The lobe's
 * factors averaged over it (nm_env_factor) set the sum; the factors at each sub-lobe's own axis
 * (nm_env_point) split it between them. NM_SUBLOBES = 1: Wang09's isotropic warp λ/(4c). */
#ifndef SGPIPE_NM_ENV_H
#define SGPIPE_NM_ENV_H

#ifndef NM_SUBLOBES
#define NM_SUBLOBES 3
#endif
#ifndef NM_EXACT_POINTS
#define NM_EXACT_POINTS 1   /* 0: the point set through each lobe's SG (gamma_points) */
#endif
#define NM_POINT_CUT 30.0f  /* a lobe's D below e^{−30} of its peak at a point: skipped */

/* ks × the material's Fresnel (nm_fres) averaged over a reflected lobe: o·h = c + uZ (Z ~
 * N(0, 1), the h-lobe's offset towards o; u = sin θ_o / √λ_h), counted where n·i > 0 (Z > −t)
 * and weighted by the Jacobian's o·h, by a 9-point midpoint rule over Z ∈ [max(−t, −4), 4]. At
 * a grazing view the axis value F(c) is near F(0) = 1 for Schlick's (1 − o·h)⁵ while most of
 * the lobe reflects at a larger o·h. */
inline float3 nm_fresnel_lobe(__global const float *m, float3 ks, int model, float c, float u,
                              float t) {
    float z0 = fmax(-t, -4.0f), dz = (4.0f - z0) / 9.0f;
    float3 num = (float3)(0.0f);
    float den = 0.0f;
    for (int k = 0; k < 9; ++k) {
        float z = z0 + ((float)k + 0.5f) * dz;
        float x = clamp(c + u * z, 0.0f, 1.0f);
        float w = exp(-0.5f * z * z) * x;
        num += w * nm_fres(m, ks, model, x);
        den += w;
    }
    return den > 0.0f ? num / den : nm_fres(m, ks, model, c);
}

/* The factors of the BRDF × cosine other than D, per unit of the warped SG, averaged over the
 * whole h-lobe about n (spread σ = 1/√λ_h per axis) reflected to its lifted axis p: view ol
 * (lifted, c = n·ol > 0), roughness a (microfacet; Blinn–Phong: σ alone). The Jacobian 4(o·h)
 * of h → i, which the warp takes as 4c, is replaced by its mean over the lobe, o·h = c +
 * sin θ_o σ Z, counted where n·i > 0 (o·h > c/2). */
inline float3 nm_env_factor(__global const float *m, float3 ks, int model, float3 n, float3 ol,
                            float3 p, float a, float sh) {
    float co = dot(n, ol), ci = dot(n, p);
    if (model == NM_BLINN) {
        /* ∫ (n·h)^e (n·i) 4(o·h) dω_h: the SG's integral holds 4c. With h offset by x towards o
         * (variance σ² = 1/e per axis), n·i = v = c + 2 sin θ_o x to first order and
         * o·h = (c + v)/2, so the mean of (n·i)(o·h) over n·i > 0 is ½(c·E[v⁺] + E[v⁺²]) for
         * v ~ N(c, τ²), τ = 2 sin θ_o σ; the second-order term of the offsets' radius,
         * −3c²σ² (c² + (2 − 5c²)σ² untruncated), counted where v > 0 */
        float c = fmax(co, 1e-3f);
        float tau = 2.0f * sqrt(fmax(1.0f - c * c, 0.0f)) * sh + 1e-7f;
        float z = c / tau;
        float Phi = 0.5f * erfc(-0.70710678f * z), phi = 0.39894228f * exp(-0.5f * z * z);
        float e1 = c * Phi + tau * phi, e2 = (c * c + tau * tau) * Phi + c * tau * phi;
        return ks * (fmax(0.5f * (c * e1 + e2) - 3.0f * c * c * sh * sh * Phi, 0.0f) / c);
    }
    float3 h = normalize(ol + p);
    float ch = dot(n, h), oh = dot(ol, h);
    /* the light-side masking over the lobe: its directions rise ~a above the axis at a grazing
     * view (the axis value alone: −53 % at 87°) */
    float cg = sqrt(ci * ci + 0.5f * a * a);
    float so = sqrt(fmax(1.0f - co * co, 1e-6f));
    float t = co / (2.0f * so * sh);
    float u = so * sh;
    float eoh = co * 0.5f * erfc(-0.70710678f * t) + u * 0.39894228f * exp(-0.5f * t * t);
    float g2;
    if (model != NM_COOK) {
        g2 = nm_mf_g(model, cg, co, ch, oh, a) * eoh;
    } else {   /* V-cavity: G·(o·h) = min(o·h, 2c) (view side), its mean over the lobe */
        float t2 = co / u;
        g2 = co * (0.5f * erfc(-0.70710678f * t2) - 0.5f * erfc(0.70710678f * t))
             + u * 0.39894228f * (exp(-0.5f * t * t) - exp(-0.5f * t2 * t2))
             + co * erfc(0.70710678f * t2);
    }
    return nm_fresnel_lobe(m, ks, model, co, u, t) * (g2 / (co * co));
}

/* The same factors at one direction p of the reflected lobe (no average: the sub-lobes' relative
 * weights), times the fraction `above` of the sub-lobe above n's horizon; Fresnel's channel
 * mean. */
inline float nm_env_point(__global const float *m, float3 ks, int model, float3 n, float3 ol,
                          float3 p, float a, float above) {
    float co = dot(n, ol), ci = dot(n, p);
    if (ci <= 0.0f) return 0.0f;
    float3 h = normalize(ol + p);
    float ch = dot(n, h), oh = fmax(dot(ol, h), 0.0f);
    if (model == NM_BLINN) return above * ci * oh / co;
    float3 F = model == NM_GLTF ? nm_fres(m, ks, model, oh) : mf_fresnel(m, oh);
    return above * (F.x + F.y + F.z) * (1.0f / 3.0f) * nm_mf_g(model, ci, co, ch, oh, a) * oh
           / (co * co);
}

/* The lobe about the unit axis n (Blinn–Phong exponent e with normalisation `norm`, or
 * microfacet roughness a with D amplitude `amp`) under the environment: its D as one SG in h of
 * the same mass, Σ over its sub-lobes of the SG's weight × factors × f̂_h(SSDF) × (Γ_L + the
 * point set's Gaussians). The SSDF is decoded once, at the centre sub-lobe; the side sub-lobes
 * take θ_d shifted by their change of elevation (exact for the horizon), as the `sg` method
 * does. GGX (a: the peak-matched roughness) keeps no tail this way: +1 … +14 % under a
 * constant environment, −13 … −44 % at views 80–87° (GGX's own SG lobes, nm_ggx_conv_lobes,
 * hold the tail, but their broad lobes' warp and factors overshoot up to ×4.5 at α 0.6;
 * tests/normalmap/test_render_env.py). */
inline float3 nm_spec_env(__global const float *m, float3 ks, int model, float3 n, float3 o,
                          float e, float norm, float a, float amp, float3 T, float3 B,
                          float3 N, const Vis *vis,
                          __global const float4 *pyr, __global const int *pyr_off,
                          __global const int *pyr_res, __global const float *pyr_lam,
                          int pyr_n, float pyr_log_ratio, float3 env_mean,
                          __global const float4 *pyr_pts, int n_pts,
                          __global const float4 *pyr_raw, int raw_n, float env_scale) {
    if (model == NM_LAMBERT) return (float3)(0.0f);
    float3 ol = nm_lift(o, n, 0.01f);
    float lam_h, amp_h;
    if (model == NM_BLINN) {          /* (n·h)^e ≈ e/(e+1)·e^{e(n·h − 1)}: the same integral */
        lam_h = e;
        amp_h = norm * e / (e + 1.0f);
    } else {  /* e^{−tan²θ/a²}, e^{−θ²/a²}, GGX's peak ≈ e^{(2/a²)(n·h − 1)}: the same mass */
        lam_h = 2.0f / (a * a);
        /* Cook–Torrance: the SG's mass πa² exceeds the θ-Gaussian's πa²(1 − a²/6) */
        amp_h = model != NM_COOK ? 1.0f / (4.0f * SG_PI * a * a)
                                 : amp * MF_INV_PI * (1.0f - a * a / 6.0f);
    }
    SG w = sg_warp(sg_make(n, lam_h, (float3)(amp_h)), ol);
    float sh = rsqrt(lam_h);
    /* the lobe's mean factors at its axis, kept one σ above n's horizon (a grazing view reflects
     * into directions above it: i = 2(o·h)h − o with n·i > 0) */
    float3 p1 = normalize(nm_lift(w.p, n, fmin(rsqrt(w.lam), 0.5f)));
    if (dot(n, p1) <= 0.0f) return (float3)(0.0f);
    float3 f1 = nm_env_factor(m, ks, model, n, ol, p1, a, sh);
#if NM_SUBLOBES == 3
    float co = dot(n, ol);
    float sig = 2.0f * sh * sqrt(fmax(1.0f - co * co, 0.0f));      /* σ_s */
#else
    float co = 1.0f, sig = 0.0f;
#endif
    float3 acc = (float3)(0.0f);
    if (sig < 1e-3f) {
        SG s = sg_times_visibility(sg_make(p1, w.lam, w.mu * f1),
                                   vis_theta(vis, to_local(p1, T, B, N)));
        acc = s.mu * (gamma_lookup_acc(pyr, pyr_off, pyr_res, pyr_lam, pyr_n, pyr_log_ratio,
                                       env_mean, pyr_raw, raw_n, p1, w.lam)
                      + gamma_points(pyr_pts, n_pts, p1, w.lam));
        return acc * env_scale;
    }
    /* three sub-lobes along the plane of incidence; their factors at their own axes weigh
     * them, the lobe's mean factors f1 set their sum (the sub-lobes' 3-point rule does not
     * hold the horizon's truncation of a grazing lobe) */
    float lam_x = lam_h / (4.0f * co * co);
    float3 ex = cross(ol, n);
    float le = length(ex);
    ex = le > 1e-7f ? ex / le : (float3)(1.0f, 0.0f, 0.0f);
    float3 ea = normalize(cross(w.p, ex));  /* in the plane of incidence, ⊥ p */
    /* a broad lobe's sub-lobes at ±√3σ_s would leave the region where a Gaussian on the
     * sphere holds its shape (toksvig's widened lobes at grazing views): ≤ 0.5 rad */
    float ang = fmin(1.7320508f * sig, 0.5f);
    float ca = cos(ang), sa = sin(ang), sx = rsqrt(lam_x);
    float3 pk[3];
    float wk[3], tot = 0.0f;
    for (int k = 0; k < 3; ++k) {
        float sgn = k == 0 ? 0.0f : (k == 1 ? 1.0f : -1.0f);
        float3 q = normalize(ca * w.p + sgn * sa * ea);
        float above = 0.5f * erfc(-0.70710678f * dot(n, q) / sx);
        pk[k] = normalize(nm_lift(q, n, fmin(sx, 0.5f)));
        wk[k] = (k == 0 ? 2.0f / 3.0f : 1.0f / 6.0f)
                * nm_env_point(m, ks, model, n, ol, pk[k], a, above);
        tot += wk[k];
    }
    if (tot <= 0.0f) return (float3)(0.0f);
    float3 mu0 = w.mu * f1 * (lam_x / w.lam);     /* the same integral as the isotropic lobe */
    float th0 = 0.0f, el0 = 0.0f;
    for (int k = 0; k < 3; ++k) {
        if (wk[k] <= 0.0f) continue;
        float3 pl = to_local(pk[k], T, B, N);
        float el = asin(clamp(pl.z, -1.0f, 1.0f));
        if (k == 0) { th0 = vis_theta(vis, pl); el0 = el; }
        float th = clamp(th0 + (el - el0), -1.5707963f, 1.5707963f);
        SG s = sg_times_visibility(sg_make(pk[k], lam_x, mu0 * (wk[k] / tot)), th);
        acc += s.mu * (gamma_lookup_acc(pyr, pyr_off, pyr_res, pyr_lam, pyr_n, pyr_log_ratio,
                                        env_mean, pyr_raw, raw_n, pk[k], lam_x)
                       + gamma_points(pyr_pts, n_pts, pk[k], lam_x));
    }
    return acc * env_scale;
}

/* E_n[a(n·o)] / a(μ·o) for the normals n ~ vMF(μ, κ) of a filtered lobe, a the material's
 * exact albedo for F ≡ 1 at a view cosine (its energy table's a1, render.energy; 0 at and
 * below the horizon): the share of the lobe's normals that see the view from below their
 * horizon, or at another elevation, which the lobe shaded at its axis does not know. The
 * vMF's 1 − cos β (density ∝ e^{−κt}) by a 4-point Gauss–Laguerre rule, its azimuth by 8
 * points; 1 without a table, for a textured pixel's record or a sharp lobe. */
inline float nm_albedo_a1(__global const float4 *t, float x) {
    if (x <= 0.0f) return 0.0f;
    float v = (clamp(x, ENERGY_COS_MIN, 1.0f) - ENERGY_COS_MIN) / (1.0f - ENERGY_COS_MIN)
              * (float)(ENERGY_VIEWS - 1);
    int v0 = min((int)floor(v), ENERGY_VIEWS - 2);
    return mix(t[v0].x, t[v0 + 1].x, v - (float)v0);
}

inline float nm_lobe_albedo_ratio(__global const float *m, __global const float *tables,
                                  float c, float kappa) {
    if (m[MAT_ETAB] < 0.0f || m[MAT_SV] > 0.5f || kappa >= 1e4f) return 1.0f;
    __global const float4 *t = (__global const float4 *)(tables + (int)m[MAT_ETAB]);
    float den = nm_albedo_a1(t, c);
    if (den <= 1e-6f) return 1.0f;
    const float xk[4] = {0.32254769f, 1.74576110f, 4.53662030f, 9.39507091f};
    const float wk[4] = {0.60315410f, 0.35741869f, 0.03888791f, 0.00053929f};
    float s = sqrt(fmax(1.0f - c * c, 0.0f)), num = 0.0f;
    for (int k = 0; k < 4; ++k) {
        float u = fmin(xk[k] / fmax(kappa, 1e-3f), 2.0f);
        float r = s * sqrt(u * (2.0f - u));
        for (int p = 0; p < 8; ++p)
            num += wk[k] * nm_albedo_a1(t, c * (1.0f - u) + r * cos(0.78539816f * (float)p));
    }
    return num / (8.0f * den);
}

/* The environment's point set (records (c_k, ·), (E_k, ·): a sun, the brightest texels) as
 * directional lights of irradiance E_k: Σ_k f̂_h(SSDF at c_k) E_k Σ_j w_j ρ_j(o, c_k)(n_j·c_k)
 * with each lobe's exact BRDF (nm_spec, lobe j's specular colour lks[j]), as the `sg` and `gmm`
 * methods shade the point set. A lobe's Gaussian fall-off as an SG in i-space bends and
 * narrows a sun's highlight at grazing views, where the reflected lobe is far from an
 * isotropic SG. */
inline float3 nm_points(__global const float *m, const float3 *lks, int model,
                        const float4 *ax, const float4 *lp, int nlob, float3 o, float3 T,
                        float3 B, float3 N, const Vis *vis, __global const float4 *pts, int n_pts,
                        __global const float4 *lobes, __global const float *tables) {
    float3 acc = (float3)(0.0f);
    if (model == NM_LAMBERT) return acc;
    for (int k = 0; k < n_pts; ++k) {
        float3 c = pts[2 * k].xyz;
        if (dot(c, N) <= 0.0f) continue;
        float3 spec = (float3)(0.0f);
        for (int j = 0; j < nlob; ++j) {
            float3 n = ax[j].xyz;
            if (dot(n, c) <= 0.0f) continue;
            float ch = dot(n, normalize(nm_lift(o, n, 0.01f) + c));
            /* Blinn–Phong (n·h)^e ≈ e^{−e(1 − n·h)}, microfacet e^{−tan²θ_h/a²}, GGX
             * (1 + tan²θ_h/a²)^{−2} */
            float x = model == NM_BLINN ? lp[j].y * (1.0f - ch)
                                        : (1.0f - ch * ch) / fmax(ch * ch * lp[j].w * lp[j].w,
                                                                  1e-12f);
            if (model == NM_GGX || model == NM_GLTF) x = 2.0f * log1p(x);
            if (model == NM_MERL) x = 0.0f;     /* its lobes' tails: no cut */
            if (ch <= 0.0f || x > NM_POINT_CUT) continue;
            spec += lp[j].x * nm_spec(m, lks[j], model, n, o, c, lp[j].y, lp[j].z, lp[j].w,
                                      ax[j].w, lobes, tables);
        }
        if (spec.x + spec.y + spec.z <= 0.0f) continue;
        acc += spec * pts[2 * k + 1].xyz
               * fh_hat(vis_theta(vis, to_local(c, T, B, N)), NM_LIGHT_LAMBDA);
    }
    return acc;
}

#endif
