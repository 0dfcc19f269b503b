/* Spherical Gaussians G(v; p, λ, μ) = μ e^{λ(v·p − 1)} (Wang09 §3, eq 2–7, 17–22, 40).
 * RGB amplitudes; every closed form evaluates only e^{x} with x <= 0 (no overflow). */
#ifndef SGPIPE_SG_H
#define SGPIPE_SG_H

#define SG_PI 3.14159265358979f
#define SG_TWO_PI 6.28318530717959f
#define SG_EPS_LN (-2.30258509299405f)   /* ln ε, ε = 0.1 (Wang09 eq 3) */

typedef struct { float3 p; float lam; float3 mu; } SG;

inline SG sg_make(float3 p, float lam, float3 mu) { SG g; g.p = p; g.lam = lam; g.mu = mu; return g; }

/* Wang09 eq 2. */
inline float3 sg_eval(SG g, float3 v) { return g.mu * exp(g.lam * (dot(v, g.p) - 1.0f)); }

/* (1 − e^{−2d}) / d, limit 2 at d → 0; from d = 9 on 1 − e^{−2d} is 1 in float32 (e^{−18} is
 * under half an ulp of 1), taken without the library expm1 (~40 cycles: the kernels ask it
 * for every light's and every Γ_L level's integral). */
inline float sg_sinhc(float d) {
    return d < 1e-4f ? 2.0f - 2.0f * d : (d >= 9.0f ? 1.0f / d : -expm1(-2.0f * d) / d);
}

/* ∫_{S²} G = 2π μ (1 − e^{−2λ}) / λ. */
inline float sg_integral_unit(float lam) { return SG_TWO_PI * sg_sinhc(lam); }
inline float3 sg_integral(SG g) { return g.mu * sg_integral_unit(g.lam); }

/* Wang09 eq 5 / 45: G1·G2 = G(v; pm/‖pm‖, λm‖pm‖, μ1μ2 e^{λm(‖pm‖−1)}). The exponent
 * d − λ1 − λ2 (d = ‖λ1p1 + λ2p2‖) is taken as −λ1λ2‖p1 − p2‖² / (λ1 + λ2 + d), the same value
 * without the cancellation that float32 suffers when the λ are large (at λ ~ 1e9, grazing
 * warped lobes, the plain difference errs by ±100 and e^{…} overflows). */
inline SG sg_product(SG a, SG b) {
    float3 pv = a.lam * a.p + b.lam * b.p;
    float d = length(pv);
    float3 dp = a.p - b.p;
    SG r;
    r.p = d > 1e-12f ? pv / d : a.p;
    r.lam = d;
    r.mu = a.mu * b.mu * exp(-a.lam * b.lam * dot(dp, dp) / (a.lam + b.lam + d + 1e-30f));
    return r;
}

/* Wang09 eq 4: ∫ G1 G2 = 2π μ1μ2 e^{d − λ1 − λ2} (1 − e^{−2d}) / d, d = ‖λ1p1 + λ2p2‖. */
inline float3 sg_inner(SG a, SG b) {
    float d = length(a.lam * a.p + b.lam * b.p);
    float3 dp = a.p - b.p;          /* d − λ1 − λ2 without cancellation, as sg_product */
    return a.mu * b.mu * (SG_TWO_PI * exp(-a.lam * b.lam * dot(dp, dp)
                                          / (a.lam + b.lam + d + 1e-30f)) * sg_sinhc(d));
}

/* ½ erfc(x) (Φ(−x√2), the normal CDF) without the library call where float32 rounds it to 1
 * (x ≤ −4: erfc(4) = 1.5e-8 is under half an ulp of 2) or to 0 (x ≥ 10.5): the call costs
 * ~45 cycles, and the cosine's and a sharp light's horizon factors mostly sit out there. */
inline float half_erfc(float x) {
    return x <= -4.0f ? 1.0f : (x >= 10.5f ? 0.0f : 0.5f * erfc(x));
}

/* sin x and cos x (returned as (sin, cos)) for the small angles of the kernels' lobe offsets:
 * Cephes' sinf / cosf polynomials on |x| ≤ π/4 (error ≤ 1e-7), the library beyond; the
 * library's calls reduce the argument out of line (~30 cycles a call) even when |x| < π/4. */
inline float2 sincos_small(float x) {
    if (fabs(x) > 0.78539816f) {
        float c, s = sincos(x, &c);
        return (float2)(s, c);
    }
    float z = x * x;
    float s = ((-1.9515295891e-4f * z + 8.3321608736e-3f) * z - 1.6666654611e-1f) * z * x + x;
    float c = ((2.443315711809948e-5f * z - 1.388731625493765e-3f) * z
               + 4.166664568298827e-2f) * z * z - 0.5f * z + 1.0f;
    return (float2)(s, c);
}

/* tan x for |x| ≤ π/4 (Cephes tanf's polynomial, relative error ≤ 2e-7), as sincos_small. */
inline float tan_small(float x) {
    if (fabs(x) > 0.78539816f) return tan(x);
    float z = x * x;
    return (((((9.38540185543e-3f * z + 3.11992232697e-3f) * z + 2.44301354525e-2f) * z
              + 5.34112807005e-2f) * z + 1.33387994085e-1f) * z + 3.33331568548e-1f) * z * x + x;
}

/* Wang09 eq 3 and inverse: f_a(λ) = −2π ln ε / λ. */
inline float sg_area(float lam) { return -SG_TWO_PI * SG_EPS_LN / lam; }
inline float sg_lambda_from_area(float area) { return -SG_TWO_PI * SG_EPS_LN / area; }

/* Wang09 eq 17–20: NDF lobe (h-space) → lobe in i-space for view o (ψ(h) = 2(o·h)h − o,
 * τ = 4|o·h|); the amplitude is kept, M_o is applied by the caller (eq 22). */
inline SG sg_warp(SG g, float3 o) {
    float oh = dot(o, g.p);
    SG r;
    r.p = normalize(2.0f * oh * g.p - o);
    r.lam = g.lam / (4.0f * fmax(fabs(oh), 1e-6f));
    r.mu = g.mu;
    return r;
}

/* Wang09 eq 40: clamped cosine max(0, i·n) ≈ G(i; n, 2.133, 1.170). */
#define SG_COS_LAMBDA 2.133f
#define SG_COS_MU 1.170f
inline SG sg_clamped_cosine(float3 n) { return sg_make(n, SG_COS_LAMBDA, (float3)(SG_COS_MU)); }

/* Töral19 eq 8: solid angle holding the fraction `a` of a lobe, Ω_s = −2π ln(1 − a) / κ. */
inline float sg_solid_angle(float lam, float a) { return -SG_TWO_PI * log(1.0f - a) / lam; }

/* vMF κ, weight w ↔ SG λ = κ, μ = w κ / (2π (1 − e^{−2κ})). */
inline float vmf_to_sg_mu(float kappa) { return 1.0f / sg_integral_unit(kappa); }

/* Quaternion (x, y, z, w) rotation of a vector (Wang09 §7 quaternion maps). */
inline float3 quat_rotate(float4 q, float3 v) {
    float3 u = q.xyz;
    float3 t = 2.0f * cross(u, v);
    return v + q.w * t + cross(u, t);
}

/* Orthonormal basis around unit a (Duff et al. 2017). */
inline void basis_around(float3 a, float3 *u, float3 *v) {
    float s = a.z >= 0.0f ? 1.0f : -1.0f;
    float p = -1.0f / (s + a.z);
    float q = a.x * a.y * p;
    *u = (float3)(1.0f + s * a.x * a.x * p, s * q, -s * a.x);
    *v = (float3)(q, s + a.y * a.y * p, -a.y);
}

inline float3 to_local(float3 d, float3 t, float3 b, float3 n) { return (float3)(dot(d, t), dot(d, b), dot(d, n)); }
inline float3 to_world(float3 d, float3 t, float3 b, float3 n) { return d.x * t + d.y * b + d.z * n; }

#endif
