/* Anisotropic spherical Gaussians (Xu, Sun, Liu, Tong, Wang 2013, eq 4) of the NDF,
 *   G(h) = c · max(h·z, 0) · e^{−λ(h·x)² − μ(h·y)²},  y = z × x,
 * warped to light space for a view o as isotropic SG sub-lobes ("1 ASG ≈ many SGs") that the
 * sg kernel integrates like its own lobes (M_o, clamped cosine, SSDF, Γ_L). Numpy mirror and
 * derivation: sgpipe/core/asg.py (asg_sublobes).
 * Lobe table (sgpipe/render/materials.py): after a material's NLOBES SG lobes one header pair
 * (0, 0, 0, 0), (0, 0, 0, n_asg), then n_asg pairs (z, λ), (c, μ, φ, 0) with x = cos φ u + sin φ v,
 * (u, v) = basis_around(z). Defines: ASG_MAX_HALF (nodes per side, default 32; a lobe that needs
 * more gets its nodes spread over the same ±3σ and each sub-lobe widened to half the spacing),
 * ASG_SPACING (2σ), ASG_MERGE_FROM (2σ of the line; beyond, nodes merge in pairs),
 * ASG_POINT_CUT (16: point Gaussians below e^{−16} skipped). */
#ifndef SGPIPE_ASG_H
#define SGPIPE_ASG_H

#include "sg.h"

#ifndef ASG_MAX_HALF
#define ASG_MAX_HALF 32
#endif
#ifndef ASG_SPACING
#define ASG_SPACING 2.0f    /* node spacing in sub-lobe σ (ripple ≤ 1.4 % against a point;
                              * core/asg.py KERNEL_SPACING_SIGMAS) */
#endif
#define ASG_FLOOR 2.0f      /* σ ≥ spacing / 2 once the node count is capped */
#define ASG_RANGE 3.0f      /* nodes span ±3 σ of the broad axis (2.5: −0.5 dB on a sun) */
#ifndef ASG_MERGE_FROM
#define ASG_MERGE_FROM 2.0f /* nodes beyond this many σ of the line merge in pairs
                              * (core/asg.py KERNEL_MERGE_FROM) */
#endif

typedef struct {
    float3 z, x, o, uh;
    float lam, mu, mass, og0, ell, dt, vline, wsum, kap1;
    int n;          /* nodes per side; 0: one lobe (kap1); < 0: none */
    int m;          /* nodes per side kept single; beyond, neighbours merge in pairs */
} ASGPlan;

/* Number of ASG lobes of a material whose SG lobes are lobes[lobe0 .. lobe0 + nsg). */
inline int asg_count(__global const float4 *lobes, int lobe0, int nsg) {
    return (int)(lobes[2 * (lobe0 + nsg) + 1].w + 0.5f);
}

/* Z(a) = ∫_{−1}^{1} e^{−a u²} du = √(π/a) erf(√a). */
inline float asg_zerf(float a) {
    if (a < 1e-6f) return 2.0f - 0.6666667f * a;
    float s = sqrt(a);
    return 1.7724539f * erf(s) / s;
}

/* Covariance of the ASG's local Gaussian at h mapped by the half-vector Jacobian (×2 in the
 * plane of incidence, ×2(o·h) across it), in the i-space basis (e_par, e_perp): its smaller
 * and larger eigenvalues and the larger one's unit eigenvector r; e_par, e_perp at h. */
inline void asg_warped_cov(float3 o, float3 h, float3 x, float lam, float mu, float *smin,
                           float *smax, float2 *r, float3 *e_par, float3 *e_perp) {
    float og = dot(o, h);
    float3 xk = normalize(x - dot(x, h) * h);
    float3 yk = cross(h, xk);
    float3 ep = cross(o, h);
    float le = length(ep);
    ep = le > 1e-7f ? ep / le : xk;
    float3 ea = cross(ep, h);
    float r00 = dot(xk, ea), r01 = dot(yk, ea), r10 = dot(xk, ep), r11 = dot(yk, ep);
    float vx = 0.5f / lam, vy = 0.5f / mu;
    /* C = J R diag(vx, vy) Rᵀ J, J = diag(2, 2og) */
    float a = 4.0f * (r00 * r00 * vx + r01 * r01 * vy);
    float b = 4.0f * og * (r00 * r10 * vx + r01 * r11 * vy);
    float d = 4.0f * og * og * (r10 * r10 * vx + r11 * r11 * vy);
    float m = 0.5f * (a + d), rr = hypot(0.5f * (a - d), b);
    *smin = fmax(m - rr, 1e-30f);
    *smax = m + rr;
    float2 v = fabs(b) > 1e-30f * (fabs(a) + fabs(d)) ? (float2)(b, *smax - a)
                                                        : (a >= d ? (float2)(1.0f, 0.0f) : (float2)(0.0f, 1.0f));
    *r = normalize(v);
    *e_par = ea;
    *e_perp = ep;
}

/* Node k ∈ [−n, n] (ordered 0, 1, −1, 2, −2, …) of a plan: its h-space angle along the line. */
inline int asg_node(int idx) { return (idx & 1) ? (idx + 1) / 2 : -(idx / 2); }

inline float asg_weight(const ASGPlan *p, float s) {
    float sn = sin(s);
    return cos(s) * exp(-sn * sn / (2.0f * p->vline));
}

/* The plan of ASG lobe record (L0, L1) seen from o (local frame): the warped covariance at the
 * axis, the h-space line along its broad eigenvector's preimage, node spacing and weights. */
inline ASGPlan asg_plan(float4 L0, float4 L1, float3 o) {
    ASGPlan p;
    p.z = normalize(L0.xyz);
    float3 u, v;
    basis_around(p.z, &u, &v);
    p.x = cos(L1.z) * u + sin(L1.z) * v;
    p.o = o;
    p.lam = L0.w;
    p.mu = L1.y;
    p.mass = L1.x * asg_zerf(p.lam) * asg_zerf(p.mu);
    p.og0 = dot(o, p.z);
    p.n = -1;
    if (p.og0 <= 1e-4f) return p;
    float smin, smax;
    float2 r;
    float3 ea, ep;
    asg_warped_cov(o, p.z, p.x, p.lam, p.mu, &smin, &smax, &r, &ea, &ep);
    float var = smax - smin;
    if (var <= 0.09f * smin) {
        p.n = 0;
        p.kap1 = rsqrt(smin * smax);
        return p;
    }
    float3 uh = (0.5f * r.x) * ea + (0.5f * r.y / p.og0) * ep;   /* J⁻¹ r */
    p.ell = length(uh);
    p.uh = uh / p.ell;
    float sd = sqrt(var);
    p.n = min((int)ceil(ASG_RANGE * sd / (ASG_SPACING * sqrt(smin))), ASG_MAX_HALF);
    p.n = max(p.n, 1);
    p.dt = fmin(ASG_RANGE * sd / (float)p.n, 1.5f / (p.ell * (float)p.n));
    float fl = p.dt / ASG_FLOOR;
    p.vline = fmax(fmax(smax - fmax(smin, fl * fl), 0.0f) * p.ell * p.ell, 1e-30f);
    p.m = min(p.n, (int)ceil(ASG_MERGE_FROM / ASG_RANGE * (float)p.n));
    p.wsum = 0.0f;
    for (int k = -p.n; k <= p.n; ++k) p.wsum += asg_weight(&p, (float)k * p.dt * p.ell);
    return p;
}

/* Sub-lobe count of a plan (0, 1 or 2(m + ⌈(n − m)/2⌉) + 1). */
inline int asg_sublobe_count(const ASGPlan *p) {
    return p->n < 0 ? 0 : (p->n == 0 ? 1 : 2 * (p->m + (p->n - p->m + 1) / 2) + 1);
}

/* Sub-lobe idx of a plan as an i-space SG (amplitude: the NDF's value, M_o not applied);
 * 0 where its microfacets face away from o. Index 0 is the lobe's centre. */
inline int asg_sublobe(const ASGPlan *p, int idx, SG *out) {
    if (p->n == 0) {
        *out = sg_make(2.0f * p->og0 * p->z - p->o, p->kap1,
                       (float3)(4.0f * p->og0 * p->mass / sg_integral_unit(p->kap1)));
        return 1;
    }
    /* slot j: node j for |j| ≤ m, else the pair (ka, ka + 1) merged with exact moments along
     * the line (weighted mean position, pair variance added along the chain) */
    int j = asg_node(idx), a = abs(j);
    int ka = a <= p->m ? a : p->m + 2 * (a - p->m) - 1;
    int kb = a <= p->m ? a : min(ka + 1, p->n);
    float step = p->dt * p->ell, sa = (float)ka * step, sb = (float)kb * step;
    float wa = asg_weight(p, sa), wb = kb > ka ? asg_weight(p, sb) : 0.0f;
    float wab = wa + wb;
    float s = (wa * sa + wb * sb) / wab;
    float vh = wa * wb * (sb - sa) * (sb - sa) / (wab * wab);
    if (j < 0) s = -s;
    float cs = cos(s), sn = sin(s);
    float3 h = cs * p->z + sn * p->uh;
    float og = dot(p->o, h);
    if (og <= 1e-4f) return 0;
    float smin, smax;
    float2 r;
    float3 ea, ep;
    asg_warped_cov(p->o, h, p->x, p->lam, p->mu, &smin, &smax, &r, &ea, &ep);
    float3 t = -sn * p->z + cs * p->uh;
    float ta = dot(t, ea), tp = dot(t, ep);
    float jt = 2.0f * sqrt(ta * ta + og * og * tp * tp);
    float fl = p->dt * p->ell * jt / ASG_FLOOR;
    /* isotropic lobe of the geometric-mean variance of (σ²_min, σ²_min + pair variance) */
    float sig2 = vh > 0.0f ? sqrt(smin * (smin + vh * jt * jt)) : smin;
    float kap = 1.0f / fmax(sig2, fl * fl);
    float w = wab / p->wsum;
    *out = sg_make(2.0f * og * h - p->o, kap,
                   (float3)(4.0f * og * p->mass * w / sg_integral_unit(kap)));
    return 1;
}

/* gamma_points (cubemap.h) skipping points whose Gaussian factor is below e^{-ASG_POINT_CUT}:
 * a chain of many sharp sub-lobes sees few of the environment's points, and the exp dominates. */
#ifndef ASG_POINT_CUT
#define ASG_POINT_CUT 16.0f
#endif
inline float3 asg_points(__global const float4 *pts, int n, float3 p, float lambda) {
    float3 acc = (float3)(0.0f);
    for (int k = 0; k < n; ++k) {
        float3 d = pts[2 * k].xyz - p;
        float q = 0.5f * lambda * dot(d, d);
        if (q < ASG_POINT_CUT) acc += pts[2 * k + 1].xyz * exp(-q);
    }
    return acc;
}

#endif
