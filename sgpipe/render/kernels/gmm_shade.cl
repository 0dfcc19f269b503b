/* Method `gmm` (Töral19 §V): per pixel the view direction in tangent space selects the
 * fitted per-view vMF mixture ρ(i, o_j)(n·i) ≈ Σ_k α_k vMF(i; μ_k, κ_k) (eq 3) — nearest view
 * (its lobes rotated with the view's mirror direction), or bilinear across views when the fit
 * is coherent — and each lobe is integrated against the environment by a lobe-sized lookup
 * of the box MIP chain (eq 6–10, cube distortion; gmm_lobe_integral):
 *   L_o ≈ Σ_k α_k · L̄(μ_k, κ_k) [· f̂_h(θ_d(μ_k), κ_k) with baseline shadows].
 * With render.gmm_points the environment's bright point set (sun, lamps) is summed exactly,
 * Σ_p E_p vMF(p; μ_k, κ_k) [· f̂_h(θ_d(p), ∞): each point shadowed at its own direction], and
 * gmm_mip holds the map without it (else gmm_mip = the whole map).
 * Diffuse not inside the lobes (includes_diffuse = 0), and purely diffuse materials, use the SG
 * light fit (Wang09 eq 39); local lights use the mixture itself: ρ cos ≈ Σ α vMF(l) times the irradiance.
 * A textured glTF material renders per pixel from the mixtures fitted at a grid of roughness
 * values with Schlick's F0 as a linear basis (view_gmm_rough; MAT_GMR*).
 * The chain is the cubemap box chain, or with GMM_DP Töral19's dual-paraboloid chain (eq 11;
 * `gmm_toral19`). gmm_mip, gmm_mip_off, gmm_mip_res, gmm_mip_n describe the chain read.
 * Defines: NV, FH_*, MAX_GMM_LOBES; optional GMM_TAPS, GMM_TAP_C, GMM_ROTATE, GMM_VIEW_BLEND,
 * GMM_DP. */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "dpmap.h"
#include "microfacet.h"
#include "shading.h"

/* Lobe integral (see gmm_lobe_integral): taps per lobe (1 = Töral19's single lookup) and
 * the tap level's texel size in units of the lobe's σ. Measured on the box chain (N = 128,
 * studio / sky_sun, κ 5…1000): relative RMS error vs quadrature 0.17–0.71 with one lookup,
 * 0.02–0.12 (studio) / 0.14–0.34 (sun) with 16 taps (docs/ARTIFACTS.md envmap/). */
#ifndef GMM_TAPS
#define GMM_TAPS 16
#endif
#ifndef GMM_TAP_C
#define GMM_TAP_C 1.0f
#endif
/* How each grid view's lobes are carried to the pixel's view (the nearest-view quantisation:
 * up to half a θ step, and 22.5° of azimuth for 8 φ views). 0: not at all (Töral19's nearest
 * view); 1: rigidly, by the rotation taking the grid view's mirror direction to the pixel's;
 * 2 (default): through each lobe's half vector, held fixed (warp_half) — the NDF stays put in
 * the tangent frame, so an anisotropic lobe keeps its orientation instead of turning with the
 * view's azimuth (rotation turned it by up to 22.5° at the φ cell borders: banding). */
#ifndef GMM_ROTATE
#define GMM_ROTATE 2
#endif
/* 1: independent fits blend the radiance of the 2 (4 for φ grids) neighbouring views instead
 * of using the nearest one (+1–3 dB, 2–4× the cost; off by default). */
#ifndef GMM_VIEW_BLEND
#define GMM_VIEW_BLEND 0
#endif
/* 1: the MIP chain is a dual paraboloid of scale gmm_dp_b (Töral19 eq 9–11), else a cube. */
#ifndef GMM_DP
#define GMM_DP 0
#endif
/* 1: a roughness entry's lobes are stretched to the pixel's α before the entries' radiance is
 * blended (GGX at α is GGX at α_e with slopes scaled by s = α/α_e: each lobe's offset from the
 * mirror direction scaled by s, its κ by 1/s²), so entries a few ln-α steps apart still blend
 * lobes of the pixel's width (0: the entries as fitted). */
#ifndef GMR_WARP
#define GMR_WARP 1
#endif
/* With baseline shadows each point of the set (a sun, lamp texels) is shadowed at its own
 * direction, decoded once per pixel for at most GMM_VIS_POINTS points (the point set's default
 * size), as sg's exact points are (the same sharpness for the SSDF horizon). */
#define GMM_VIS_POINTS 256
#define GMM_POINT_LAMBDA 2e4f

/* cube_mip's trilinear fetch between levels l0 and l1 = l0 + 1 (weight f), the face
 * coordinates computed once (the bordered per-level addressing of cube_bilinear). */
inline float3 gmm_trilinear(__global const float4 *mip, int off0, int n0, int off1, int n1,
                            float f, float3 d, float b) {
    float s, t;
#if GMM_DP
    int hemi = dp_coords(d, b, &s, &t);
    float3 c = (1.0f - f) * dp_bilinear_st(mip, off0, n0, hemi, s, t);
    if (f <= 0.0f) return c;
    return c + f * dp_bilinear_st(mip, off1, n1, hemi, s, t);
#else
    int face = cube_coords(d, &s, &t);
    float3 c = (1.0f - f) * cube_bilinear_st(mip, off0, n0, face, s, t);
    if (f <= 0.0f) return c;
    return c + f * cube_bilinear_st(mip, off1, n1, face, s, t);
#endif
}

/* ∫ vMF(ω; a, κ) L(ω) dω from the box MIP chain (Töral19 eq 6–10, made lobe-shaped).
 * GMM_TAPS == 1: Töral19's single trilinear lookup at the eq 10 level (a box of ~Ω_s: its
 * shape and grid alignment, not the lobe's, set the result). Otherwise GMM_TAPS equal-weight
 * taps at the vMF's radial quantiles (golden-angle azimuths), each a trilinear fetch at the
 * level whose texel is h = GMM_TAP_C·σ (σ² = 1/κ, eq 9 distortion); the taps follow a vMF of
 * variance σ² − v_f, v_f = h²/4 the variance of the box+bilinear (+ level blend) filter, so
 * that both add up to the lobe's σ². Mirrored by sgpipe.envmap.mip.MipChain.lobe_integral. */
inline float3 gmm_lobe_integral(__global const float4 *mip, __global const int *off,
                                __global const int *res, int nlev, float3 a, float kappa,
                                float coverage, float b) {
#if GMM_TAPS == 1 && GMM_DP
    return dp_mip(mip, off, res, nlev, b, a, dp_lobe_lod(a, kappa, coverage, res[0], b));
#elif GMM_TAPS == 1
    return cube_mip(mip, off, res, nlev, a, cube_lobe_lod(a, kappa, coverage, res[0]));
#else
    float sig2 = 1.0f / fmax(kappa, 1e-4f);
#if GMM_DP
    float om0 = dp_texel_solid_angle(a, res[0], b);         /* finest texel: h0² (sr) */
#else
    float om0 = cube_texel_solid_angle(a, res[0]);          /* finest texel: h0² (sr) */
#endif
    float lod = clamp(0.5f * log2(GMM_TAP_C * GMM_TAP_C * sig2 / om0), 0.0f, (float)(nlev - 1));
    float l0 = floor(lod), f = lod - l0;
    float vf = 0.25f * om0 * exp2(2.0f * l0) * (1.0f + 3.0f * f);
    /* a lobe within the finest texel's filter: the taps would all hit the same 2×2 texels */
    if (sig2 <= 0.5f * vf && lod <= 0.0f)
        return gmm_trilinear(mip, off[0], res[0], off[0], res[0], 0.0f, a, b);
    float kp = 1.0f / fmax(sig2 - vf, 0.1f * sig2);
    int i0 = (int)l0, i1 = min(i0 + 1, nlev - 1);
    int off0 = off[i0], n0 = res[i0], off1 = off[i1], n1 = res[i1];
    float e2 = exp(-2.0f * kp);
    float3 bu, bv;
    basis_around(a, &bu, &bv);
    float3 acc = (float3)(0.0f);
    float cp = 1.0f, sp = 0.0f;                 /* azimuth i·golden angle, by recurrence */
    const float cg = -0.7373688781f, sg = -0.6754902942f;
    for (int i = 0; i < GMM_TAPS; ++i) {
        float u1 = ((float)i + 0.5f) / (float)GMM_TAPS;
        float w = clamp(1.0f + log(u1 + (1.0f - u1) * e2) / kp, -1.0f, 1.0f);
        float r = sqrt(fmax(0.0f, 1.0f - w * w));
        float3 d = normalize(r * cp * bu + r * sp * bv + w * a);
        float c2 = cp * cg - sp * sg;
        sp = sp * cg + cp * sg; cp = c2;
        acc += gmm_trilinear(mip, off0, n0, off1, n1, f, d, b);
    }
    return acc * (1.0f / (float)GMM_TAPS);
#endif
}

/* ∫ vMF(ω; a, κ) L_pts(ω) dω of the point set kept out of gmm_mip (records (c_k, 0), (E_k, 0),
 * world directions; n = 0 with render.gmm_points off): Σ_k E_k vMF(c_k; a, κ), exact for point
 * masses, vMF(ω) = κ/(2π(1 − e^{−2κ})) e^{κ(a·ω − 1)} (Töral19 eq 2). */
inline float3 gmm_points_integral(__global const float4 *pts, int n, float3 a, float kappa) {
    if (n <= 0) return (float3)(0.0f);
    return vmf_to_sg_mu(kappa) * gamma_points(pts, n, a, kappa);
}

/* The same sum with each point k shadowed by its own visibility pvis[k] (a delta light's
 * shadow is the SSDF at its direction; the lobe's f̂_h would let a rim-hidden sun through
 * wherever the lobe's axis clears the rim). */
inline float3 gmm_points_integral_vis(__global const float4 *pts, int n, float3 a, float kappa,
                                      const float *pvis) {
    float3 acc = (float3)(0.0f);
    for (int k = 0; k < n; ++k) {
        if (pvis[k] <= 0.0f) continue;
        float3 d = pts[2 * k].xyz - a;       /* c·a − 1 = −½|c − a|² (no cancellation) */
        acc += pvis[k] * pts[2 * k + 1].xyz * exp(-0.5f * kappa * dot(d, d));
    }
    return vmf_to_sg_mu(kappa) * acc;
}

/* Carry lobe (axis, κ) fitted at view og to view op through its half vector h = (a + og)/‖·‖
 * held fixed (the NDF is what stays put): a' = 2(op·h)h − op, and κ scaled by the reflection
 * Jacobian dω_i = 4(o·h) dω_h: κ' = κ (og·h)/(op·h). */
inline float3 warp_half(float3 og, float3 op, float3 a, float *kappa) {
    float3 hv = a + og;
    float l2 = dot(hv, hv);
    if (l2 < 1e-8f) return a;
    hv *= rsqrt(l2);
    float og_h = dot(og, hv), op_h = dot(op, hv);
    if (op_h <= 1e-3f) return a;
    *kappa *= fmin(og_h / op_h, 4.0f);      /* grazing: bounded, like the views it comes from */
    return 2.0f * op_h * hv - op;
}

/* The shortest-arc rotation taking unit a to unit b, applied to v (a·b > −1). */
inline float3 rotate_between(float3 a, float3 b, float3 v) {
    float c = dot(a, b);
    float3 x = cross(a, b);
    return v * c + cross(x, v) + x * (dot(x, v) / fmax(1.0f + c, 1e-6f));
}

/* Lobe k of view (t, p): α RGB, κ, axis (local BRDF frame; iso fits rotated to azimuth phi0). */
inline void gmm_lobe(__global const float4 *gmm, int base, int np, int K, int t, int p, int k,
                     float phi_view, float3 *alpha, float *kappa, float3 *axis) {
    int row = base + 2 * ((t * np + p) * K + k);
    float4 a = gmm[row], b = gmm[row + 1];
    *alpha = a.xyz;
    *kappa = a.w;
    float phi = phi_view + 3.14159265358979f + b.y;
    float st = sin(b.x);
    *axis = (float3)(st * cos(phi), st * sin(phi), cos(b.x));
}

__kernel void gmm_shade(GMM_SHADE_ARGS)
{
    SHADE_PIXEL_PROLOGUE;
    /* Textures scale the fitted lobes by the texel / base-colour ratio (SVBRDF). */
    float3 ks0 = mat3(m, MAT_KS), kd0 = mat3(m, MAT_KD);
    float3 ks_ratio = select((float3)(1.0f), ks / ks0, isgreater(ks0, (float3)(0.0f)));
    float3 kd_ratio = select((float3)(1.0f), kd / kd0, isgreater(kd0, (float3)(0.0f)));

    float3 col = (float3)(0.0f);
    int base = (int)m[MAT_GMM];
    int gflags = (int)m[MAT_GMM_FLAGS];
    int with_diffuse_lobes = (gflags & VIEW_GMM_INCLUDES_DIFFUSE) != 0;
    /* A purely diffuse material's "slice" is the broad cosine lobe, far coarser than a lobe-sized
     * MIP lookup can resolve: it takes the irradiance form (SG light fit) like the diffuse part
     * of every other material. */
    if (with_diffuse_lobes && (int)m[MAT_NLOBES] == 0) { base = -1; with_diffuse_lobes = 0; }
    /* A textured isotropic gltf_pbr (m is the pixel's record, MAT_SV = 1) with mixtures per
     * roughness (view_gmm_rough): the two entries around the pixel's α, their radiance blended
     * linearly in ln α, each lobe's amplitude a0 + F0 (a1 − a0) from the pixel's F0 (the
     * specular slice is linear in Schlick's F0); the diffuse outside the lobes. */
    int n_ent = 1, ebase[2] = {base, base};
    float ew[2] = {1.0f, 0.0f}, ewarp[2] = {1.0f, 1.0f};
    int grid = base >= 0 && m[MAT_SV] > 0.5f && m[MAT_GMR] >= 0.0f;
    float3 f0 = mat3(m, MAT_F0);
    if (grid) {
        int ne = (int)m[MAT_GMR_N];
        int rows = 2 * (int)m[MAT_GMM_NT] * (int)m[MAT_GMM_NP] * (int)m[MAT_GMM_K];
        float step = ne > 1 ? (log(m[MAT_GMR_A1]) - log(m[MAT_GMR_A0])) / (float)(ne - 1) : 0.0f;
        float la = log(m[MAT_AV]) - log(m[MAT_GMR_A0]);   /* ln(α / α of the first entry) */
        float g = ne > 1 ? clamp(la / step, 0.0f, (float)(ne - 1)) : 0.0f;
        int e0 = min((int)floor(g), max(ne - 2, 0));
        float fe = g - (float)e0;
        ebase[0] = (int)m[MAT_GMR] + e0 * rows;
        ebase[1] = ebase[0] + rows;
        ew[0] = 1.0f - fe; ew[1] = fe;
        ewarp[0] = exp(la - (float)e0 * step);
        ewarp[1] = exp(la - (float)(e0 + 1) * step);
        n_ent = fe > 0.0f ? 2 : 1;
        gflags &= VIEW_GMM_COHERENT;
        with_diffuse_lobes = 0;
    }
    /* The point set's visibility, once per pixel for every lobe (the first GMM_VIS_POINTS
     * points; any further ones take their lobe's f̂_h as the MIP chain does). */
    float pvis[GMM_VIS_POINTS];
    int n_pv = (base >= 0 && !(flags & FLAG_NO_ENV_SPECULAR)
                && !(flags & FLAG_NO_VISIBILITY)) ? min(n_gmm_pts, GMM_VIS_POINTS) : 0;
    for (int k = 0; k < n_pv; ++k)
        pvis[k] = fh_hat(vis_theta(&vis, to_local(pyr_pts[2 * k].xyz, T, B, N)),
                         GMM_POINT_LAMBDA);
    if (base >= 0) {
        int nt = (int)m[MAT_GMM_NT], np = (int)m[MAT_GMM_NP];
        int K = min((int)m[MAT_GMM_K], MAX_GMM_LOBES);
        float th = acos(clamp(op.z, -1.0f, 1.0f));
        float ph = atan2(op.y, op.x);
        if (ph < 0.0f) ph += 2.0f * 3.14159265358979f;
        float tc = clamp(th / fmax(m[MAT_GMM_TMAX], 1e-6f) * (float)(nt - 1), 0.0f,
                         (float)(nt - 1));
        float pc = np > 1 ? ph / (2.0f * 3.14159265358979f) * (float)np : 0.0f;
        /* Coherent fits (lobe k matches across views): lobes interpolated bilinearly.
         * Independent fits: the radiance of the neighbouring views' mixtures is blended
         * (GMM_VIEW_BLEND; else the nearest view). Either way each grid view's lobes are first
         * carried along with its mirror direction to the pixel's (GMM_ROTATE). */
        int coherent = (gflags & VIEW_GMM_COHERENT) && interp;
        int blend = coherent || (interp && GMM_VIEW_BLEND);
        int t0 = blend ? min((int)floor(tc), max(nt - 2, 0)) : (int)(tc + 0.5f);
        float ft = blend && nt > 1 ? tc - (float)t0 : 0.0f;
        int p0 = blend ? (int)floor(pc) : (int)(pc + 0.5f);
        float fp = blend && np > 1 ? pc - floor(pc) : 0.0f;
        p0 = np > 1 ? p0 % np : 0;
        int t1 = min(t0 + 1, nt - 1), p1 = np > 1 ? (p0 + 1) % np : 0;
        float w[4] = {(1 - ft) * (1 - fp), ft * (1 - fp), (1 - ft) * fp, ft * fp};
        int tt[4] = {t0, t1, t0, t1}, pp[4] = {p0, p0, p1, p1};
        float3 mpix = (float3)(-op.x, -op.y, op.z);
        float3 scale = grid ? (float3)(1.0f) : with_diffuse_lobes ? kd_ratio : ks_ratio;
        int n_pass = coherent ? 1 : 4;
        for (int e = 0; e < n_ent; ++e)
        for (int pass = 0; pass < n_pass; ++pass) {
            base = ebase[e];
            if (!coherent && w[pass] <= 0.0f) continue;
            for (int k = 0; k < K; ++k) {
                float3 alpha = (float3)(0.0f), axis = (float3)(0.0f);
                float kappa = 0.0f, wsum = 0.0f;
                for (int c = coherent ? 0 : pass; c < (coherent ? 4 : pass + 1); ++c) {
                    if (w[c] <= 0.0f) continue;
                    float phv = np > 1 ? 2.0f * 3.14159265358979f * (float)pp[c] / (float)np : ph;
                    float3 a, ax; float kp;
                    gmm_lobe(gmm, base, np, K, tt[c], pp[c], k, phv, &a, &kp, &ax);
#if GMR_WARP
                    if (grid) {        /* the entry's lobes stretched to the pixel's α */
                        float s = clamp(ewarp[e], 0.25f, 4.0f);
                        float tv0 = m[MAT_GMM_TMAX] * (float)tt[c] / (float)max(nt - 1, 1);
                        float3 mg = (float3)(-sin(tv0) * cos(phv), -sin(tv0) * sin(phv),
                                             cos(tv0));
                        ax = normalize(mg + s * (ax - mg));
                        kp /= s * s;
                    }
#endif
#if GMM_ROTATE == 2
                    float tv = m[MAT_GMM_TMAX] * (float)tt[c] / (float)max(nt - 1, 1);
                    float3 og = (float3)(sin(tv) * cos(phv), sin(tv) * sin(phv), cos(tv));
                    ax = warp_half(og, op, ax, &kp);
#elif GMM_ROTATE
                    float tv = m[MAT_GMM_TMAX] * (float)tt[c] / (float)max(nt - 1, 1);
                    float3 mg = (float3)(-sin(tv) * cos(phv), -sin(tv) * sin(phv), cos(tv));
                    ax = rotate_between(mg, mpix, ax);
#endif
                    alpha += w[c] * a; kappa += w[c] * kp; axis += w[c] * ax; wsum += w[c];
                }
                kappa /= fmax(wsum, 1e-12f);       /* alpha keeps the pass weight */
                if (grid) alpha = ew[e] * (alpha.x + f0 * (alpha.y - alpha.x));
                if (kappa <= 0.0f || dot(axis, axis) < 1e-12f) continue;
                axis = normalize(axis);
                float3 ag = quat_rotate(q, axis);
                float3 aw = normalize(to_world(ag, T, B, N));
                float vis_f = (flags & FLAG_NO_VISIBILITY) ? 1.0f
                                                          : fh_hat(vis_theta(&vis, ag), kappa);
                if (!(flags & FLAG_NO_ENV_SPECULAR))
                    col += alpha * scale * env_scale
                           * (vis_f * (gmm_lobe_integral(gmm_mip, gmm_mip_off, gmm_mip_res,
                                                         gmm_mip_n, aw, kappa, coverage,
                                                         gmm_dp_b)
                                       + gmm_points_integral(pyr_pts + 2 * n_pv,
                                                             n_gmm_pts - n_pv, aw, kappa))
                              + gmm_points_integral_vis(pyr_pts, n_pv, aw, kappa, pvis));
                for (int l = 0; l < n_lights; ++l) {
                    SG Lw = light_sg(lights[2 * l], lights[2 * l + 1], x);
                    float3 lg = to_local(Lw.p, T, B, N);
                    float3 E = sg_integral(Lw);
                    float pdf = vmf_to_sg_mu(kappa) * exp(kappa * (dot(axis, quat_rotate(qi, lg)) - 1.0f));
                    float v = (flags & FLAG_NO_VISIBILITY) ? 1.0f : fh_hat(vis_theta(&vis, lg), Lw.lam);
                    col += alpha * scale * pdf * E * v;
                }
            }
        }
    }
    /* Diffuse outside the fitted slice: Wang09 eq 39 with the SG light fit (+ lights). */
    if (!with_diffuse_lobes) {
        SG cosg = sg_clamped_cosine(quat_rotate(q, (float3)(0.0f, 0.0f, 1.0f)));
        if (!(flags & FLAG_NO_ENV_DIFFUSE))
            col += diffuse_env_sg(m, kd, op, q, qi, T, B, N, env_sg, n_env_sg, env_scale, &vis);
        for (int l = 0; l < n_lights; ++l) {
            SG Lw = light_sg(lights[2 * l], lights[2 * l + 1], x);
            SG g = sg_product(cosg, sg_make(to_local(Lw.p, T, B, N), Lw.lam, Lw.mu));
            float3 fd = mf_diffuse(m, kd, op, lift(quat_rotate(qi, g.p), 0.05f));
            col += fd * sg_dot_visibility(g, vis_theta(&vis, g.p));
        }
    }
    out[gid] = (float4)(col, 1.0f);
}
