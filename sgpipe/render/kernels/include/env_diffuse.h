/* The environment's diffuse SG-light sum (Wang09 eq 39, shading.h diffuse_env_sg) evaluated
 * ENV_LANES lobes at a time in float8 lanes. PoCL's CPU device does not vectorise this kernel
 * across work-items (its work-item loop holds data-dependent inner loops), so each pixel runs
 * scalar code; the 8 SG lights of an environment fit (envmap.lightfit: 1–9 lobes) are the
 * widest independent work a pixel has, and as lanes their exp, log, sqrt, asin and the
 * concentric-square map cost one vector call per 8 lobes instead of one call each. Only the
 * SSDF taps stay per lobe (each lobe reads its own texels). Same arithmetic as the per-lobe
 * sg_light_diffuse (tests/render: the sg frame either way). Needs sg.h, ssdf.h, microfacet.h
 * and shading.h's Vis, SHARP_LIGHT, lift and quat_rotate first. */
#ifndef SGPIPE_ENV_DIFFUSE_H
#define SGPIPE_ENV_DIFFUSE_H

#define ENV_LANES 8

typedef struct { float8 x, y, z; } Dir8;     /* 8 directions, one per lane */

inline float lane_sum8(float8 a) { float4 c = a.lo + a.hi; return c.x + c.y + c.z + c.w; }

/* ssdf.h ssdf_atan_unit per lane. */
inline float8 ssdf_atan_unit8(float8 t) {
    float8 at = fabs(t);
    int8 big = at > 0.41421356f;
    float8 x = big ? (at - 1.0f) / (at + 1.0f) : at;
    float8 z = x * x;
    return copysign(SSDF_ATAN_POLY(x, z) + (big ? (float8)(SSDF_PI_4) : (float8)(0.0f)), t);
}

/* ssdf.h hemisphere_to_square (and disk_to_square) per lane → (u, v). */
inline void hemisphere_to_square8(Dir8 d, float8 *u, float8 *v) {
    float8 z = clamp(d.z, 0.0f, 1.0f);
    float8 rho = sqrt(d.x * d.x + d.y * d.y);
    float8 sc = z > 0.5f ? rsqrt(1.0f + z) : sqrt(1.0f - z) / rho;
    sc = rho > 0.0f ? sc : (float8)(0.0f);
    float8 x = d.x * sc, y = d.y * sc;
    float8 rr = sqrt(x * x + y * y);
    int8 major_x = fabs(x) >= fabs(y);
    float8 num = major_x ? y : x, den = major_x ? x : y;
    float8 s = den >= 0.0f ? rr : -rr;
    float8 pa = s * ssdf_atan_unit8(den != 0.0f ? num / den : (float8)(0.0f))
                * (1.0f / SSDF_PI_4);
    *u = 0.5f * ((major_x ? s : pa) + 1.0f);
    *v = 0.5f * ((major_x ? pa : s) + 1.0f);
}

#if NV > 0
/* ssdf.h ssdf_decode_square per lane: the taps and weights of all lanes at once, then each
 * lane's NV-term sums, written out in one loop so that the lanes' loads overlap. */
inline float8 ssdf_decode8(__global const float *basis, __global const float *mean, int res,
                           const ssdf_vec *w, float8 u, float8 v) {
    float8 x = u * (float)res - 0.5f, y = v * (float)res - 0.5f;
    float8 x0f = floor(x), y0f = floor(y);
    float8 fx = x - x0f, fy = y - y0f;
    int8 xi = convert_int8(x0f), yi = convert_int8(y0f);
    int8 x0 = clamp(xi, 0, res - 1), x1 = clamp(xi + 1, 0, res - 1);
    int8 y0 = clamp(yi, 0, res - 1), y1 = clamp(yi + 1, 0, res - 1);
    int t00[ENV_LANES], t10[ENV_LANES], t01[ENV_LANES], t11[ENV_LANES];
    float w00[ENV_LANES], w10[ENV_LANES], w01[ENV_LANES], w11[ENV_LANES], out[ENV_LANES];
    vstore8(y0 * res + x0, 0, t00);
    vstore8(y0 * res + x1, 0, t10);
    vstore8(y1 * res + x0, 0, t01);
    vstore8(y1 * res + x1, 0, t11);
    vstore8((1.0f - fx) * (1.0f - fy), 0, w00);
    vstore8(fx * (1.0f - fy), 0, w10);
    vstore8((1.0f - fx) * fy, 0, w01);
    vstore8(fx * fy, 0, w11);
    for (int i = 0; i < ENV_LANES; ++i) {
        __global const float *b00 = basis + t00[i] * NV, *b10 = basis + t10[i] * NV;
        __global const float *b01 = basis + t01[i] * NV, *b11 = basis + t11[i] * NV;
        ssdf_vec acc = (ssdf_vec)(0.0f);
        for (int j = 0; j < SSDF_NW; ++j)
            acc += w[j] * (w00[i] * ssdf_vload(j, b00) + w10[i] * ssdf_vload(j, b10)
                           + w01[i] * ssdf_vload(j, b01) + w11[i] * ssdf_vload(j, b11));
        out[i] = w00[i] * mean[t00[i]] + w10[i] * mean[t10[i]] + w01[i] * mean[t01[i]]
                 + w11[i] * mean[t11[i]] + ssdf_hsum(acc);
    }
    return vload8(0, out);
}
#endif

/* shading.h vis_theta per lane: the lanes' concentric-square points at once, then one
 * ssdf_decode_square per lane. */
inline float8 vis_theta8(const Vis *v, Dir8 d) {
    float8 z = clamp(d.z, -1.0f, 1.0f);
    float8 th;
#if NV > 0
    if (v->has) {
        int8 up = z >= 0.0f;
        float8 rxy2 = d.x * d.x + d.y * d.y;
        int8 pole = ~up & (rxy2 < 1e-20f);       /* ℓ = −n: S_h := 0, θ_d = asin z */
        float8 s = pole ? (float8)(0.0f) : rsqrt(rxy2);
        Dir8 e;                                  /* below the horizon: the horizon under it */
        e.x = up ? d.x : d.x * s;
        e.y = up ? d.y : d.y * s;
        e.z = up ? d.z : (float8)(0.0f);
        float8 u8, v8;
        hemisphere_to_square8(e, &u8, &v8);
        float8 dv = ssdf_decode8(v->basis, v->mean, v->res, v->w, u8, v8);
        th = dv;
        if (!all(up)) {
            float8 as = asin(z);
            th = up ? dv : (pole ? as : fmin(dv, 0.0f) + as);
        }
    } else
#endif
    {
        th = asin(z);
    }
    float lim = fmin(v->maxd, 1.5707963f);
    return clamp(th, -lim, lim);
}

/* quat_rotate per lane (q shared). */
inline Dir8 quat_rotate8(float4 q, Dir8 v) {
    Dir8 t, r;
    t.x = 2.0f * (q.y * v.z - q.z * v.y);
    t.y = 2.0f * (q.z * v.x - q.x * v.z);
    t.z = 2.0f * (q.x * v.y - q.y * v.x);
    r.x = v.x + q.w * t.x + (q.y * t.z - q.z * t.y);
    r.y = v.y + q.w * t.y + (q.z * t.x - q.x * t.z);
    r.z = v.z + q.w * t.z + (q.x * t.y - q.y * t.x);
    return r;
}

/* shading.h lift per lane, where `on` (lanes of the broad lobes). */
inline Dir8 lift8(Dir8 d, float zmin, int8 on) {
    int8 low = on & (d.z < zmin);
    float8 l = sqrt(d.x * d.x + d.y * d.y);
    int8 ok = l > 1e-8f;
    float8 r = sqrt(1.0f - zmin * zmin);
    Dir8 o;
    o.x = low ? (ok ? d.x / l : (float8)(1.0f)) * r : d.x;
    o.y = low ? (ok ? d.y / l : (float8)(0.0f)) * r : d.y;
    o.z = low ? (float8)(zmin) : d.z;
    return o;
}

/* sg.h sg_integral_unit per lane. */
inline float8 sg_integral_unit8(float8 lam) {
    float8 big = 1.0f / lam;
    if (all(lam >= 9.0f)) return SG_TWO_PI * big;
    return SG_TWO_PI * (lam < 1e-4f ? 2.0f - 2.0f * lam
                                    : (lam >= 9.0f ? big : -expm1(-2.0f * lam) / lam));
}

#ifdef FH_TABLE
/* ssdf.h fh_pair_scaled per lane, its f̂_h (x) where `want_x`, else λ·f_h (y). */
inline float8 fh_pair8(float8 theta_d, float8 lam, int8 want_x) {
    float8 x = (log(fmax(lam, FH_TAB_LAMMIN)) - FH_TAB_L0) / (FH_TAB_L1 - FH_TAB_L0)
               * (float)(FH_TAB_NL - 1);
    float8 y = (clamp(theta_d, -1.5707963f, 1.5707963f) + 1.5707963f) / 3.14159265f
               * (float)(FH_TAB_NT - 1);
    int8 x0 = clamp(convert_int8(floor(x)), 0, FH_TAB_NL - 2);
    int8 y0 = clamp(convert_int8(floor(y)), 0, FH_TAB_NT - 2);
    float8 fx = clamp(x - convert_float8(x0), 0.0f, 1.0f);
    float8 fy = clamp(y - convert_float8(y0), 0.0f, 1.0f);
    int idx[ENV_LANES], wx[ENV_LANES];
    float gx[ENV_LANES], gy[ENV_LANES], out[ENV_LANES];
    vstore8(x0 * FH_TAB_NT + y0, 0, idx);
    vstore8(want_x, 0, wx);
    vstore8(fx, 0, gx);
    vstore8(fy, 0, gy);
    for (int i = 0; i < ENV_LANES; ++i) {
        __constant const float2 *r0 = (__constant const float2 *)FH_TAB + idx[i];
        __constant const float2 *r1 = r0 + FH_TAB_NT;
        float2 f = mix(mix(r0[0], r0[1], gy[i]), mix(r1[0], r1[1], gy[i]), gx[i]);
        out[i] = wx[i] ? f.x : f.y;
    }
    float8 tab = vload8(0, out);
    int8 planar = lam >= FH_TAB_LAMMAX;
    if (!any(planar)) return tab;
    float8 p = 0.5f * erfc(-theta_d * sqrt(lam) * 0.70710678f);
    return planar ? (want_x ? p : 6.28318531f * p) : tab;
}
#endif

/* Σ_k f_d · (C* ⊗ L*_k) · V^d over the environment's SG lights (shading.h diffuse_env_sg),
 * ENV_LANES lobes a pass (padded lanes: μ = 0). A lobe at least SHARP_LIGHT sharp takes its
 * sharp limit E = ∫L · max(0, n′·l) · f̂_h(θ_d(l), λ) at l (sg_light_diffuse). */
inline float3 diffuse_env_sg8(__global const float *m, float3 kd, float3 op, float4 q,
                              float4 qi, float3 T, float3 B, float3 N,
                              __global const float4 *env_sg, int n_env_sg, float env_scale,
                              const Vis *vis) {
    float3 fd3;                          /* f_d = fd3 · mf_diffuse_lane(i) */
    if (!mf_diffuse_colour(m, kd, op, &fd3)) return (float3)(0.0f);
    float3 cn = quat_rotate(q, (float3)(0.0f, 0.0f, 1.0f));   /* C*'s axis */
    float3 acc = (float3)(0.0f);
    for (int k0 = 0; k0 < n_env_sg; k0 += ENV_LANES) {
        float ax[ENV_LANES], ay[ENV_LANES], az[ENV_LANES], al[ENV_LANES];
        float mr[ENV_LANES], mg[ENV_LANES], mb[ENV_LANES];
        for (int i = 0; i < ENV_LANES; ++i) {
            int k = k0 + i;
            float4 a = k < n_env_sg ? env_sg[2 * k] : (float4)(0.0f, 0.0f, 1.0f, 1.0f);
            float4 b = k < n_env_sg ? env_sg[2 * k + 1] * env_scale : (float4)(0.0f);
            ax[i] = a.x; ay[i] = a.y; az[i] = a.z; al[i] = a.w;
            mr[i] = b.x; mg[i] = b.y; mb[i] = b.z;
        }
        float8 wx = vload8(0, ax), wy = vload8(0, ay), wz = vload8(0, az);
        float8 lam = vload8(0, al);
        Dir8 l;                                            /* to_local */
        l.x = wx * T.x + wy * T.y + wz * T.z;
        l.y = wx * B.x + wy * B.y + wz * B.z;
        l.z = wx * N.x + wy * N.y + wz * N.z;
        int8 sharp = lam >= SHARP_LIGHT;
        /* broad: g = C* ⊗ L (sg.h sg_product, a = C*) */
        float8 px = SG_COS_LAMBDA * cn.x + lam * l.x, py = SG_COS_LAMBDA * cn.y + lam * l.y;
        float8 pz = SG_COS_LAMBDA * cn.z + lam * l.z;
        float8 d = sqrt(px * px + py * py + pz * pz);
        float8 dx = cn.x - l.x, dy = cn.y - l.y, dz = cn.z - l.z;
        int8 dok = d > 1e-12f;
        float8 ex = exp(-SG_COS_LAMBDA * lam * (dx * dx + dy * dy + dz * dz)
                        / (SG_COS_LAMBDA + lam + d + 1e-30f));
        Dir8 g;          /* the direction V^d is read at: g's axis, or the sharp light's */
        g.x = sharp ? l.x : (dok ? px / d : (float8)(cn.x));
        g.y = sharp ? l.y : (dok ? py / d : (float8)(cn.y));
        g.z = sharp ? l.z : (dok ? pz / d : (float8)(cn.z));
        Dir8 f = lift8(quat_rotate8(qi, g), 0.05f, ~sharp);   /* f_d's direction */
        float8 th = vis_theta8(vis, g);
        float8 e;                                /* E / μ_L: the lane's scalar factor */
#ifdef FH_TABLE
        float8 lf = sharp ? lam : fmax(d, FH_TAB_LAMMIN);
        float8 fh = fh_pair8(th, lf, sharp);
        float8 e_broad = SG_COS_MU * ex * (fh / lf);
        float8 e_sharp = fh;
#else
        float thv[ENV_LANES], lv[ENV_LANES], dd[ENV_LANES], out[ENV_LANES];
        vstore8(th, 0, thv);
        vstore8(lam, 0, lv);
        vstore8(d, 0, dd);
        for (int i = 0; i < ENV_LANES; ++i)
            out[i] = lv[i] >= SHARP_LIGHT ? fh_hat(thv[i], lv[i])
                     : sg_dot_visibility(sg_make((float3)(0.0f, 0.0f, 1.0f), dd[i],
                                                 (float3)(1.0f)), thv[i]).x;
        float8 fh = vload8(0, out);
        float8 e_broad = SG_COS_MU * ex * fh;
        float8 e_sharp = fh;
#endif
        e = e_broad;
        if (any(sharp)) {
            int8 lit = (f.z > 0.0f) & (l.z > 0.0f);
            e_sharp = lit ? sg_integral_unit8(lam) * (f.z * e_sharp) : (float8)(0.0f);
            e = sharp ? e_sharp : e_broad;
        }
        float8 c = mf_diffuse_lane(m, op, f.x, f.y, f.z) * e;
        acc += (float3)(lane_sum8(c * vload8(0, mr)), lane_sum8(c * vload8(0, mg)),
                        lane_sum8(c * vload8(0, mb)));
    }
    return fd3 * acc;
}

#endif
