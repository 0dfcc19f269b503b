/* Green06 §3.2/§5 on the device: a vertex's Gaussians interpolated across the three nearest of
 * the 92 views (gnomonic barycentrics of the geodesic triangle the view ray crosses), then
 * across the hit triangle's vertices — blending parameters (μ normalised, σ, the lobe's
 * integral), never values.
 * Mirrors sgpipe.transport.interp (blend_gaussians, interpolate_views) and views.nearest_views.
 * Gaussian record (sgpipe.render.transport_data): per (vertex, view, k) two float4,
 * (μ.xyz, σ) and (w.rgb, 0), at ((vertex·92 + view)·K + k)·2. */
#ifndef SGPIPE_TRANSPORT_H
#define SGPIPE_TRANSPORT_H

#define TP_VIEWS 92
#define TP_VIEW_FACES 180
#define TP_MAX_K 4

/* The three views around q and their weights (views.nearest_views): the first hull face whose
 * cone holds q (β = M⁻¹ q ≥ 0, M's columns the face's views), β clamped at 0 and normalised.
 * vinv: per face the three rows of M⁻¹ (float4 ×3); vtri: per face its view indices. */
inline void tp_nearest_views(float3 q, __global const float4 *vinv, __global const int4 *vtri,
                             int *iv, float *bv) {
    int face = 0;
    float3 beta = (float3)(1.0f, 0.0f, 0.0f);
    /* −1e-6 instead of interp's −1e-12: float32 roundoff on shared edges (both faces give the
     * same blend there, the third weight being ~0) */
    for (int f = 0; f < TP_VIEW_FACES; ++f) {
        float3 b = (float3)(dot(vinv[3 * f].xyz, q), dot(vinv[3 * f + 1].xyz, q),
                            dot(vinv[3 * f + 2].xyz, q));
        if (b.x >= -1e-6f && b.y >= -1e-6f && b.z >= -1e-6f) { face = f; beta = b; break; }
    }
    beta = fmax(beta, (float3)(0.0f));
    beta /= (beta.x + beta.y + beta.z);
    int4 t = vtri[face];
    iv[0] = t.x; iv[1] = t.y; iv[2] = t.z;
    bv[0] = beta.x; bv[1] = beta.y; bv[2] = beta.z;
}

/* interp.lobe_area: ∫ exp((ω·μ − 1)/σ²) dω / 2π = σ² (1 − e^{−2/σ²}), 0 at σ = 0. */
inline float tp_lobe_area(float s) {
    float s2 = s * s;
    return s2 > 0.0f ? -s2 * expm1(-2.0f / s2) : 0.0f;
}

/* blend_gaussians for one Gaussian: μ = normalize(Σ b_i μ_i) (μ_0 when the sum vanishes),
 * σ = Σ b_i σ_i, and w with w A(σ) = Σ b_i w_i A(σ_i): the integrals blend linearly (blending
 * w and σ separately overshoots between a narrow bright and a broad dim lobe). */
inline void tp_blend(const float3 *mu, const float *sig, const float3 *w, const float *b,
                     float3 *mu_o, float *sig_o, float3 *w_o) {
    float3 m = b[0] * mu[0] + b[1] * mu[1] + b[2] * mu[2];
    float l = length(m);
    *mu_o = l > 0.0f ? m / l : mu[0];
    float s = b[0] * sig[0] + b[1] * sig[1] + b[2] * sig[2];
    *sig_o = s;
    float3 a = b[0] * tp_lobe_area(sig[0]) * w[0] + b[1] * tp_lobe_area(sig[1]) * w[1]
               + b[2] * tp_lobe_area(sig[2]) * w[2];
    float as = tp_lobe_area(s);
    *w_o = as > 0.0f ? a / as : (float3)(0.0f);
}

/* interpolate_views for Gaussian k of vertex `vert` (global row) at the views iv, weights bv. */
inline void tp_vertex_gaussian(__global const float4 *gauss, int vert, int K, int k,
                               const int *iv, const float *bv, float3 *mu, float *sig, float3 *w) {
    float3 m[3], ww[3];
    float s[3];
    for (int i = 0; i < 3; ++i) {
        __global const float4 *r = gauss + 2 * ((vert * TP_VIEWS + iv[i]) * K + k);
        float4 a = r[0];
        m[i] = a.xyz; s[i] = a.w; ww[i] = r[1].xyz;
    }
    tp_blend(m, s, ww, bv, mu, sig, w);
}

#endif
