/* `sg`'s departure from Wang09 eq 31: an environment lobe cut by the visibility boundary (the
 * SSDF's, or the tangent plane's) rendered as the L2-closest single SG to its visible part
 * (sgpipe.core.fh_clip, docs/MATH.md). Needs sg.h, ssdf.h and shading.h (Vis, vis_theta). */
#ifndef SGPIPE_CLIP_H
#define SGPIPE_CLIP_H

/* The direction of steepest ascent of θ_d at the unit direction p (a unit tangent at p): the
 * tangent plane's horizon analytically (towards +z), the SSDF's from two one-sided differences
 * (step VIS_GRAD_STEP rad); where the SSDF is flat there (clamped at its range) the horizon's. */
#define VIS_GRAD_STEP 0.03f
inline float3 vis_gradient(const Vis *v, float3 p, float th) {
    float3 up = (float3)(0.0f, 0.0f, 1.0f) - p.z * p;
    float lu = length(up);
    float3 g = lu > 1e-6f ? up / lu : (float3)(1.0f, 0.0f, 0.0f);
#if NV > 0
    if (v->has) {
        float3 e2 = normalize(cross(p, g));
        float d1 = vis_theta(v, normalize(p + VIS_GRAD_STEP * g)) - th;
        float d2 = vis_theta(v, normalize(p + VIS_GRAD_STEP * e2)) - th;
        float lg = sqrt(d1 * d1 + d2 * d2);
        if (lg > 1e-4f) g = (d1 * g + d2 * e2) / lg;
    }
#endif
    return g;
}

/* The visible part of the SG s cut by the boundary at signed angular distance θ_d from its
 * centre (g: the unit tangent at s.p pointing away from the boundary) as one SG
 * (core.fh_clip): the centre turned by δ towards g, the sharpness λ', the integral eq 31's
 * f̂_h(θ_d, λ) times the lobe's; (δ √λ, ln λ'/λ) minimise the L2 distance to the clipped lobe
 * (fh_clip.h, bilinear in ln λ × u = θ_d √max(λ, CLIP_LAMC)). Eq 31 keeps the centre and
 * sharpness: a lobe centred behind a rim or below the horizon then reads its light from
 * behind it, and a broad lobe (λ ≲ 2) from the whole sphere. */
#include "fh_clip.h"
inline float2 clip_params(float th, float lam) {
    float x = (log(clamp(lam, 1e-30f, 1e30f)) - CLIP_L0) / (CLIP_L1 - CLIP_L0)
              * (float)(CLIP_NL - 1);
    float u = th * sqrt(fmax(lam, CLIP_LAMC));
    float y = (clamp(u, -CLIP_U, CLIP_U) + CLIP_U) / (2.0f * CLIP_U) * (float)(CLIP_NT - 1);
    x = clamp(x, 0.0f, (float)(CLIP_NL - 1));
    int x0 = min((int)x, CLIP_NL - 2), y0 = min((int)y, CLIP_NT - 2);
    float fx = x - (float)x0, fy = y - (float)y0;
    __constant const float2 *r0 = (__constant const float2 *)CLIP_TAB + x0 * CLIP_NT + y0;
    __constant const float2 *r1 = r0 + CLIP_NT;
    return mix(mix(r0[0], r0[1], fy), mix(r1[0], r1[1], fy), fx);
}
/* whether the lobe is the table's identity there (sharper than CLIP_LAMC, ≥ CLIP_U σ inside) */
inline int clip_none(float th, float lam) {
    return lam >= CLIP_LAMC && th * sqrt(lam) >= CLIP_U;
}
inline SG sg_clip_visible(SG s, float th, float3 g) {
    float f = fh_hat(th, s.lam);
    if (f <= 0.0f) { s.mu = (float3)(0.0f); return s; }
    float2 c = clip_params(th, s.lam);
    float d = c.x * rsqrt(s.lam);
    SG o;
    float2 sc = sincos_small(d);
    o.p = normalize(sc.y * s.p + sc.x * g);
    o.lam = s.lam * exp(c.y);
    o.mu = s.mu * (f * sg_integral_unit(s.lam) / sg_integral_unit(o.lam));
    return o;
}

#endif
