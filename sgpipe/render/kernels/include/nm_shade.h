/* Han07 normal-map filtering (Algorithm 2, eq 12, 20–21, 24–26): helpers of the `vmf`,
 * `normals_mip`, `toksvig`, `engine_bake` and `nm_sh` kernels; their common body is
 * nm_shade_body.h, included inside each kernel, the filter chosen by NM_FILTER. `vmf_han07`
 * is the vmf kernel with methods.HAN07_SWITCHES' defines (NM_PUB_*: trilinear lookup, eq 24 at
 * level 0, §8's SH environment in nm_env_sh.h), `nm_sh_han07` the nm_sh kernel with
 * HAN07_SH_SWITCHES' (trilinear γ_lm at every level, eq 12 truncated at l* = ⌈√(4s)⌉).
 *   lookup  trilinear in the pixel's texture footprint (isotropic level log2 of the longer UV
 *           derivative in texels, or N taps along the longer one; sgpipe.scene.footprint), of
 *           α_j and α_j·r_j (eq 24), then r = αr/α, κ = (3|r| − |r|³)/(1 − |r|²), μ = r/|r|
 *           (sgpipe.normalmap.vmf.lookup); the SH method's γ_lm and the mean normal n̄ likewise.
 *           Box footprint (render.normalmap_footprint: box; nm_brdf slot NM_FOOT_SLOT): the
 *           reference's box pixel filter — the footprint's box of widths w_u = |∂u/∂(x, y)|,
 *           w_v = |∂v/∂(x, y)| (texels), at the finest level ℓ where it overlaps ≤ NM_BOX_TEXELS
 *           texels, NDF(pixel) = Σ_t A_t/(w_u w_v) NDF_t (A_t: the box's overlap with texel t,
 *           exact for the level's piecewise-constant NDFs), every texel's J lobes kept apart
 *           (α_j ← A_t α_j/(w_u w_v)); level 0: a grid of ≤ NM_BOX_L0_TAPS² bilinear normals
 *   vmf     per lobe the material's specular lobe about μ_j with the convolved parameter:
 *           Blinn–Phong s′ = κs/(κ+s) (eq 20, normalised (s′+1)/(2π) and scaled by the
 *           material's ks (s+2)/(8π)·2π/(s+1)), Beckmann α′ = √(α² + 2/κ), Cook–Torrance
 *           m′ = √(m² + 2/κ) with the amplitude m²/m′² (eq 21, α = m = 2σ); the cosine, masking,
 *           the 1/(n·i)(n·o) factor and the view lift taken at the lobe axis, Fresnel at o·h;
 *           diffuse kd/π · max(0, n̄·i) with n̄ the plain MIP of the normals (linear in the NDF);
 *           a measured (MERL) material (eq 14 for its fitted D*): each of its record's NDF SG
 *           lobes convolved with vMF(κ) by λ′ = λκ/(λ + κ), mass kept, times M_o at the lobe
 *           axis (nm_merl_d, nm_merl_m); the single-lobe methods convolve by their own κ
 *           (nm_merl_kappa); under the environment the `sg` specular of those lobes
 *   normals_mip  the material's BRDF at n̄/|n̄|
 *   toksvig Blinn–Phong exponent f·s, f = r/(r + s(1 − r)); microfacet roughness
 *           α′² = α² + 2(1 − r)/r (the same variance, Blinn–Phong s ≈ 2/α²); r = |n̄| of the
 *           filtered mean, per fetch (Toksvig 2005), but 1 for level 0's box taps (a bilinear
 *           read between two texels is shorter without the map being rough there)
 *   engine_bake  one lobe about n̄/|n̄| with κ = (3r − r³)/(1 − r²), then eq 20/21
 *           (Filament / Godot: α′ = √(α² + 2/κ)); r baked: each texel's own |n̄| (the mean
 *           slot's w), filtered like the roughness texture an engine stores (level 0: 1)
 *   nm_sh   eq 12: ρ_eff(ω) = Σ_lm ρ̂_l γ_lm Y_lm(ω), ω = ω_h for the specular lobe (the
 *           BRDF's remaining factors and the cosine at n̄, §4.3), ω = ω_i with Lambert's ρ̂_l
 *           (l ≤ 2) for the diffuse term.
 * Environment: specular per lobe (eq 24–26 with an SG in place of SH): the lobe's effective
 * D about μ as an SG in h (Blinn–Phong λ = s′; Beckmann / Cook–Torrance λ = 2/α′²), warped to
 * i-space about the reflected view with its anisotropy (three sub-lobes, nm_env.h), times the
 * BRDF's other factors at each sub-lobe's axis, through the accurate Γ_L pyramid
 * (gamma_lookup_acc, the `sg` method's); GGX, glTF and measured materials: the `sg`
 * method's specular of their NDF lobes convolved with the lobe's vMF (nm_terms_body.h). nm_sh's
 * specular lobe for the environment is the engine_bake lobe (n̄, κ(|n̄|)): general SH do not
 * rotate cheaply (Han07 footnote 9). Diffuse: the `sg` method's SG-light sum
 * about n̄ (diffuse_env_sg), nm_sh: Σ_{l ≤ 2} Â_l γ_lm L_lm with γ rotated to world.
 * Lights are delta lights of the records' intensity (as the reference's default).
 * Shadows: the object's SSDF visibility (shading.h, vis_*), lights as a hard horizon
 * (f̂_h at λ = 2·10⁴), environment lobes through sg_times_visibility; off under
 * FLAG_NO_VISIBILITY. Layout of nm_*: sgpipe/render/normalmap_data.py. */
#ifndef SGPIPE_NM_SHADE_H
#define SGPIPE_NM_SHADE_H
#include "ggx_conv.h"
#include "asg.h"
#include "sg_specular.h"    /* the bare GGX material's environment specular (sg's lobes) */

#define NM_VMF 0
#define NM_MIP 1
#define NM_TOKSVIG 2
#define NM_BAKE 3
#define NM_SH 4
#define NM_INV_2PI 0.159154943091895f
#define NM_MAX_LOBES 8      /* normalmap.lobes ≤ 8 */
#define NM_MAX_L0 16        /* level-0 normals kept apart (more taps: summed modulo 16) */
#define NM_MAX_SH4 73       /* float4 of γ_lm per texel: (l* + 1)² ≤ 289 (l* ≤ 16) */
#define NM_BRDF_STRIDE 36   /* floats per object in nm_brdf */
#define NM_RHO_SLOT 16      /* nm_brdf: ρ̂_0 … ρ̂_16 of the specular function (eq 11) */
#define NM_RHO_N 17
#define NM_RHO_F4 5         /* float4 per entry of a ρ̂ table (nm_rho_at) */
#define NM_RHOTAB_SLOT 33   /* nm_brdf: 1 + the ρ̂ table's float4 offset in nm_data, 0 none */
#define NM_LAMBERT 0
#define NM_BLINN 1
#define NM_BECKMANN 2
#define NM_COOK 3
#define NM_GGX 4            /* GGX, separable Smith G1·G1 (model `ggx`) */
#define NM_GLTF 5           /* GGX, height-correlated Smith G2 (`gltf_pbr`: its diffuse too) */
#define NM_MERL 6           /* measured: its record's NDF SG lobes × M_o (Wang09 eq 13) */
#define NM_LIGHT_LAMBDA 2e4f  /* delta lights' sharpness for the SSDF horizon (shading.h cap) */
#define NM_FEAT_SLOT 12     /* nm_brdf: colour features (eq 22): 1 kd/ks multipliers, 2 glTF */
#define NM_GLTF_MIN_R 0.06f /* glTF roughness floor (brdf.models.GLTF_MIN_ROUGHNESS) */
#define NM_FOOT_SLOT 14     /* nm_brdf: render.normalmap_footprint (0 trilinear, 1 box) */
#define NM_LSTAR_SLOT 15    /* nm_brdf: Han07 §5's l* ≈ √(4s) (normalmap_data.published_sh_order) */
#define NM_BOX_TEXELS 9     /* box footprint: texels of its level it may overlap */
#define NM_BOX_L0_TAPS 4    /* box footprint at level 0: bilinear-normal taps per edge */
#ifndef NM_L0_TAPS_PER_TEXEL
#define NM_L0_TAPS_PER_TEXEL 6.0f
#endif

/* Bilinear fetch of slot `slot` (of `stride` per texel) of a level at (off, side m): repeat
 * addressing, row 0 = v = 1, texel centres at half-integers (vmf.bilinear, tex_bilinear). */
inline float4 nm_bilinear(__global const float4 *d, int off, int m, int stride, int slot,
                          float2 uv) {
    float x = (uv.x - floor(uv.x)) * (float)m - 0.5f;
    float y = (1.0f - (uv.y - floor(uv.y))) * (float)m - 0.5f;
    float x0f = floor(x), y0f = floor(y);
    float fx = x - x0f, fy = y - y0f;
    int x0 = (int)x0f, y0 = (int)y0f;
    x0 = x0 < 0 ? x0 + m : (x0 >= m ? x0 - m : x0);
    y0 = y0 < 0 ? y0 + m : (y0 >= m ? y0 - m : y0);
    int x1 = x0 + 1 == m ? 0 : x0 + 1, y1 = y0 + 1 == m ? 0 : y0 + 1;
    __global const float4 *t = d + off + slot;
    float4 a = t[(y0 * m + x0) * stride] * (1.0f - fx) + t[(y0 * m + x1) * stride] * fx;
    float4 b = t[(y1 * m + x0) * stride] * (1.0f - fx) + t[(y1 * m + x1) * stride] * fx;
    return a * (1.0f - fy) + b * fy;
}

/* A glTF sampler's CLAMP_TO_EDGE axes (nm_info.w bits 1 and 2): the UV held inside [0, 1]
 * (the texels within half a texel of the edge still blend with the opposite edge). */
inline float2 nm_wrap_uv(float2 uv, int w) {
    if (w & 2) uv.x = clamp(uv.x, 0.0f, 1.0f);
    if (w & 4) uv.y = clamp(uv.y, 0.0f, 1.0f);
    return uv;
}

/* Box footprint along one texel axis: the interval [c − w/2, c + w/2] (texel units of a level
 * of side m, texel k covering [k, k + 1), repeat addressing) over the texels it overlaps: their
 * indices (wrapped) and weights overlap / w (summing to 1), at most `cap`; the count, or cap + 1
 * when more would be needed. w is clamped to m (a box wider than the map covers it whole). */
inline int nm_box_axis(float c, float w, int m, int cap, int *idx, float *wt) {
    w = clamp(w, 1e-6f, (float)m);
    float a = c - 0.5f * w, b = c + 0.5f * w;
    int k0 = (int)floor(a), k1 = (int)ceil(b) - 1;
    if (k1 - k0 + 1 > cap) return cap + 1;
    for (int k = k0; k <= k1; ++k) {
        int q = k % m;
        idx[k - k0] = q < 0 ? q + m : q;
        wt[k - k0] = (fmin(b, (float)(k + 1)) - fmax(a, (float)k)) / w;
    }
    return k1 - k0 + 1;
}

/* κ of a lobe from its mean resultant length r (Algorithm 2 line 9, Banerjee's estimate; r ≥ 1:
 * a single normal, κ = ∞ as 1e30). */
inline float nm_kappa_of(float r) {
    return r >= 1.0f ? 1e30f : (3.0f * r - r * r * r) / (1.0f - r * r);
}

/* Eq 21 per vMF lobe: the squared roughness of the material's D convolved with vMF(κ) (slope
 * variance σ² = 1/κ per axis). Beckmann and Cook–Torrance: a² + 2σ², their Gaussian slopes'
 * variances adding. GGX's slopes have no variance: the GGX whose peak is the convolution's on
 * the sphere (sgpipe.core.ggx_conv: the plane-of-slopes form a² + σ²(2 + 2/√(1 +
 * 6.84σ²/a²)) times the tabulated ratio, bilinear in ln a, ln(σ/a), clamped to the grid). */
inline float nm_convolved_a2(int model, float a, float kappa) {
    float v = 1.0f / fmax(kappa, 1e-30f);
    if (model != NM_GGX && model != NM_GLTF) return a * a + 2.0f * v;
    if (v <= 0.0f) return a * a;
    float a2 = fmax(a * a, 1e-12f);
    float x = clamp((log(a) - GGXC_LA0) / GGXC_DLA, 0.0f, (float)(GGXC_NA - 1));
    float y = clamp((0.5f * log(v / a2) - GGXC_LR0) / GGXC_DLR, 0.0f, (float)(GGXC_NR - 1));
    int i = min((int)x, GGXC_NA - 2), j = min((int)y, GGXC_NR - 2);
    float fx = x - (float)i, fy = y - (float)j;
    __constant const float *t = GGXC_TAB + i * GGXC_NR + j;
    float lr = (1.0f - fx) * ((1.0f - fy) * t[0] + fy * t[1])
               + fx * ((1.0f - fy) * t[GGXC_NR] + fy * t[GGXC_NR + 1]);
    return (a2 + v * (2.0f + 2.0f * rsqrt(1.0f + 6.84f * v / a2))) * exp(lr);
}

/* The single-lobe methods' lobe from the mean normal's length rl (has_map 0: the material's
 * own lobe): (e, norm, a) and the D amplitude *amp — toksvig: e = f·s, f = rl/(rl + s(1 − rl)),
 * α′² = α² + 2(1 − rl)/rl; engine_bake / nm_sh: κ = (3rl − rl³)/(1 − rl²), eq 20 / 21;
 * normals_mip: the material's lobe. */
inline float3 nm_single_lobe(int filter, int has_map, float rl, float s, float bnorm,
                             float *amp) {
    float e = s, nrm = (s + 2.0f) * 0.125f * MF_INV_PI, a = s;
    *amp = 1.0f;
    if (has_map && filter == NM_TOKSVIG) {
        e = s * rl / (rl + s * (1.0f - rl));
        nrm = (e + 2.0f) * 0.125f * MF_INV_PI;
        float a2 = s * s + 2.0f * (1.0f - rl) / fmax(rl, 1e-6f);
        a = sqrt(a2); *amp = s * s / a2;
    } else if (has_map && (filter == NM_BAKE || filter == NM_SH)) {
        float kappa = nm_kappa_of(rl);
        e = kappa > 1e20f ? s : kappa * s / (kappa + s);
        nrm = bnorm * (e + 1.0f);
        float a2 = s * s + 2.0f / fmax(kappa, 1e-6f);
        a = sqrt(a2); *amp = s * s / a2;
    }
    return (float3)(e, nrm, a);
}

/* Level 0's taps as lobes: a tap whose unit normal n lies within NM_MERGE_COS of the axis of a
 * lobe j in [from, n) with the same parameters (D amplitude, e, norm, a = par) adds its weight
 * w to that lobe instead of becoming one (the taps on a flat facet of the map share one
 * normal), its colours ckd, cks blended into the lobe's lkd[j], lks[j] by weight; 1 when
 * merged. */
#define NM_MERGE_COS 0.99995f   /* 0.01 rad */
inline int nm_merge_tap(float4 *ax, float4 *lp, float3 *lkd, float3 *lks, int from, int n,
                        float3 nk, float w, float4 par, float3 ckd, float3 cks) {
    for (int j = from; j < n; ++j) {
        if (dot(ax[j].xyz, nk) > NM_MERGE_COS && ax[j].w == par.x && lp[j].y == par.y
            && lp[j].z == par.z && lp[j].w == par.w) {
            float w0 = lp[j].x;
            ax[j].xyz = normalize(w0 * ax[j].xyz + w * nk);
            lp[j].x = w0 + w;
            float u = w / lp[j].x;
            lkd[j] += (ckd - lkd[j]) * u;
            lks[j] += (cks - lks[j]) * u;
            return 1;
        }
    }
    return 0;
}

/* The environment's diffuse term (the `sg` method's SG-light sum, diffuse_env_sg) for a unit
 * normal d (world) seen from o. */
#ifndef NM_DIFF_LOBES
#define NM_DIFF_LOBES 3     /* vmf: lobes whose environment diffuse is taken at their own axes */
#endif
inline float3 nm_env_diffuse_at(__global const float *m, float3 kd, float3 o, float3 d,
                                float3 T, float3 B, float3 N, __global const float4 *env_sg,
                                int n_env_sg, float env_scale, const Vis *vis) {
    float4 q = quat_from_z(normalize(to_local(d, T, B, N)));
    float4 qi = quat_conj(q);
    float3 op = lift(normalize(quat_rotate(qi, lift(to_local(o, T, B, N), 0.01f))), 0.01f);
    return diffuse_env_sg(m, kd, op, q, qi, T, B, N, env_sg, n_env_sg, env_scale, vis);
}

/* Trilinear fetch between levels l0 and l0 + 1 with weight f (f = 0: l0 only) of slot `slot`
 * of `stride` per texel in the level's block `which`: 0 the lobes (α_j, α_j·r_j), 1 the mean
 * normal, 2 the SH coefficients γ_lm (nm_levels: lobe, mean, SH offsets in x, z, w). */
inline float4 nm_trilinear(__global const float4 *d, __global const int4 *lev, int l0, int l1,
                           float f, int which, int stride, int slot, float2 uv) {
    int4 a = lev[l0];
    float4 v = nm_bilinear(d, which == 0 ? a.x : (which == 1 ? a.z : a.w), a.y, stride, slot, uv);
    if (f > 0.0f) {
        int4 b = lev[l1];
        float4 w = nm_bilinear(d, which == 0 ? b.x : (which == 1 ? b.z : b.w), b.y, stride,
                               slot, uv);
        v = v * (1.0f - f) + w * f;
    }
    return v;
}

/* Trilinear fetch of lobe j's colour features (eq 22: α_j·kd.rgb, α_j·ks.r in *c0,
 * α_j·ks.gb in *c1) between levels l0 and l1 with weight f; the block follows each level's J
 * lobes. */
inline void nm_feat_trilinear(__global const float4 *d, __global const int4 *lev, int l0,
                              int l1, float f, int nlobes, int j, float2 uv, float4 *c0,
                              float4 *c1) {
    int4 a = lev[l0];
    int o = a.x + a.y * a.y * nlobes;
    *c0 = nm_bilinear(d, o, a.y, 2 * nlobes, 2 * j, uv);
    *c1 = nm_bilinear(d, o, a.y, 2 * nlobes, 2 * j + 1, uv);
    if (f > 0.0f) {
        int4 b = lev[l1];
        int q = b.x + b.y * b.y * nlobes;
        *c0 = *c0 * (1.0f - f) + f * nm_bilinear(d, q, b.y, 2 * nlobes, 2 * j, uv);
        *c1 = *c1 * (1.0f - f) + f * nm_bilinear(d, q, b.y, 2 * nlobes, 2 * j + 1, uv);
    }
}

/* Raise a unit direction to elevation ≥ asin(zmin) about the unit axis n (shading.h's lift in
 * the frame of n; the reference's mapped_view). */
inline float3 nm_lift(float3 d, float3 n, float zmin) {
    float c = dot(d, n);
    if (c >= zmin) return d;
    float3 p = d - c * n;
    float l = length(p);
    p = l > 1e-8f ? p / l : (float3)(0.0f);
    return p * sqrt(1.0f - zmin * zmin) + zmin * n;
}

/* Normalised Blinn–Phong ρ_s (n·h)-lobe times the cosine, for exponent e about axis n:
 * norm·(n·h)^e·(n·i) (ks excluded). `norm`: the lobe's normalisation factor. */
inline float nm_blinn(float3 n, float3 o, float3 i, float e, float norm) {
    float ci = dot(n, i);
    if (ci <= 0.0f) return 0.0f;
    float3 h = normalize(nm_lift(o, n, 0.01f) + i);
    return norm * pow(fmax(dot(n, h), 0.0f), e) * ci;
}

/* Smith–Beckmann G1 of a direction at cosine c to the normal, roughness a (isotropic). */
inline float nm_g1_beckmann(float c, float a) {
    float c2 = fmax(c * c, 1e-12f);
    float t = a * a * fmax(1.0f - c2, 0.0f) / c2;
    if (t <= 0.0f) return 1.0f;
    float x = rsqrt(t);
    if (x >= 6.0f) return 1.0f;
    float lam = 0.5f * (erf(x) - 1.0f) + exp(-x * x) / (2.0f * x * MF_SQRT_PI);
    return 1.0f / (1.0f + lam);
}

/* GGX's Smith Λ-term √(1 + a² tan²θ) of a direction at cosine c to the normal. */
inline float nm_ggx_root(float c, float a) {
    float c2 = fmax(c * c, 1e-12f);
    return sqrt(1.0f + a * a * fmax(1.0f - c2, 0.0f) / c2);
}

/* GGX's D/4 at roughness alpha as GGXG_K SGs about the axis, Σ_k mu_k e^{lam_k (n·h − 1)}
 * (the roughness grid of fit.ndf_sg_rough: ln λ and μ linear in ln α, clamped to the grid),
 * each convolved with vMF(κ) (κ ≥ 1e20: none) by the SG rule λ′ = λκ/(λ + κ) with its mass
 * kept, μ′ = μλ′/λ — a GGX convolved with a vMF is no GGX (its core takes the vMF's shape), a
 * sum of SGs stays one (relative L2 of D 0.2–1.3 % against quadrature, the best single GGX
 * 5–15 %). */
inline void nm_ggx_conv_lobes(float alpha, float kappa, float *lam, float *mu) {
    float g = clamp((log(alpha) - GGXG_L0) / GGXG_DL, 0.0f, (float)(GGXG_N - 1));
    int i = min((int)g, GGXG_N - 2);
    float t = g - (float)i;
    float peak = 1.0f / (4.0f * SG_PI * alpha * alpha);
    for (int k = 0; k < GGXG_K; ++k) {
        float l = exp((1.0f - t) * GGXG_LLAM[i * GGXG_K + k] + t * GGXG_LLAM[(i + 1) * GGXG_K + k]);
        float u = (1.0f - t) * GGXG_MU[i * GGXG_K + k] + t * GGXG_MU[(i + 1) * GGXG_K + k];
        float lc = kappa >= 1e20f ? l : l * kappa / (l + kappa);
        lam[k] = lc;
        mu[k] = peak * u * lc / l;
    }
}

#include "nm_merl.h"    /* measured materials: their fitted NDF lobes, M_o */

/* Microfacet D (the fit stage's peak-normalised form times M_o's 1/π and g_scale, i.e. what
 * multiplies F·G2/((n·i)(n·o))) at cosine ch for roughness a (Beckmann: e^{−tan²/a²}/(4πa²ch⁴);
 * Cook–Torrance: amp·e^{−(θ_h/a)²}/π; GGX: a²/(4π(ch²(a² − 1) + 1)²), or with amp = −κ < 0 — a
 * vmf lobe — the lobe's GGX of roughness a0 (the material's, or its own: eq 22) convolved with
 * vMF(κ), nm_ggx_conv_lobes). */
inline float nm_mf_d(int model, float ch, float a, float amp, float a0) {
    if (ch <= 0.0f) return 0.0f;
    if ((model == NM_GGX || model == NM_GLTF) && amp < 0.0f) {
        float lam[GGXG_K], mu[GGXG_K], d = 0.0f;
        nm_ggx_conv_lobes(a0, -amp, lam, mu);
        for (int k = 0; k < GGXG_K; ++k) d += mu[k] * exp(lam[k] * (ch - 1.0f));
        return d;
    }
    if (model == NM_GGX || model == NM_GLTF) {
        float a2 = a * a, d = ch * ch * (a2 - 1.0f) + 1.0f;
        return a2 / (4.0f * SG_PI * d * d);
    }
    if (model == NM_BECKMANN) {
        float c2 = ch * ch;
        return exp(-fmin((1.0f - c2) / (c2 * a * a), 80.0f)) / (4.0f * SG_PI * a * a * c2 * c2);
    }
    float th = acos(fmin(ch, 1.0f)) / a;
    return amp * MF_INV_PI * exp(-th * th);
}

/* Masking-shadowing G2 of the microfacet models about axis n (Beckmann, GGX: Smith's G1·G1 at
 * roughness a; glTF: GGX's height-correlated 2/(√(1 + a²tan²θ_o) + √(1 + a²tan²θ_i));
 * Cook–Torrance: the V-cavity term). */
inline float nm_mf_g(int model, float ci, float co, float ch, float oh, float a) {
    if (model == NM_BECKMANN) return nm_g1_beckmann(co, a) * nm_g1_beckmann(ci, a);
    if (model == NM_GGX)
        return 4.0f / ((1.0f + nm_ggx_root(co, a)) * (1.0f + nm_ggx_root(ci, a)));
    if (model == NM_GLTF) return 2.0f / (nm_ggx_root(co, a) + nm_ggx_root(ci, a));
    oh = fmax(oh, 1e-6f);
    return fmin(1.0f, fmin(2.0f * ch * co / oh, 2.0f * ch * ci / oh));
}

/* A lobe's specular colour times the material's Fresnel at cosine c: ks·F(c); glTF lobes carry
 * their F0 as ks (each lobe its own with material features, eq 22): Schlick's F0 + (1 − F0)(1 −
 * c)⁵, the glTF BRDF's (its ks is 1). */
inline float3 nm_fres(__global const float *m, float3 ks, int model, float c) {
    return model == NM_GLTF ? fresnel_schlick(ks, c) : ks * mf_fresnel(m, c);
}

/* Specular BRDF × cosine (per unit irradiance, ks and Fresnel included) of one lobe about the
 * unit axis n: Blinn–Phong exponent e with normalisation `norm` (ρ·cos = norm (n·h)^e (n·i)),
 * or a microfacet model at roughness a with D amplitude `amp` (GGX: e holds the lobe's own
 * roughness before its vMF, nm_mf_d's a0; a measured material: amp = −κ, nm_merl_d, its
 * record's lobes in `lobes` and shadow table in `tables`). */
inline float3 nm_spec(__global const float *m, float3 ks, int model, float3 n, float3 o,
                      float3 i, float e, float norm, float a, float amp,
                      __global const float4 *lobes, __global const float *tables) {
    if (model == NM_LAMBERT) return (float3)(0.0f);
    if (model == NM_BLINN) return ks * nm_blinn(n, o, i, e, norm);
    float ci = dot(n, i);
    if (ci <= 0.0f) return (float3)(0.0f);
    float3 ol = nm_lift(o, n, 0.01f);
    if (model == NM_MERL) {
        float3 hl;
        float3 f = nm_merl_m(m, tables, ks, n, ol, i, &hl);
        return f * nm_merl_d(m, lobes, hl, amp);
    }
    float co = dot(n, ol);
    float3 h = normalize(ol + i);
    float ch = dot(n, h), oh = dot(ol, h);
    float D = nm_mf_d(model, ch, a, amp, e);
    if (D <= 0.0f) return (float3)(0.0f);
    float G = nm_mf_g(model, ci, co, ch, oh, a);
    return nm_fres(m, ks, model, oh) * (G * D / co);
}

#include "nm_env.h"

#include "nm_sh_basis.h"
#include "nm_env_sh.h"

/* The normal-map kernels' prologue (shading.h's SHADE_PIXEL_PROLOGUE without its per-pixel
 * normal-map fetch and quaternion, which these methods replace by the filtered pyramids):
 * threads past n return; locals N, T, B, x, uv, kd, ks (their textures filtered over the
 * pixel's footprint, as sg, gmm and fis read them: the plain MIP of the colour), m, ob and the
 * SSDF state `vis` (off under FLAG_NO_VISIBILITY). The map's +y runs along B = w (n × t),
 * w the tangent's handedness (as pixel_init reads every normal map). A textured gltf_pbr
 * material's record is the pixel's (shading.h gltf_pixel_record: base colour, metallic and
 * roughness filtered over the footprint; sv_ = 1), as sg reads it. */
#define NM_PIXEL_PROLOGUE \
    int gid = get_global_id(0); \
    if (gid >= n) return; \
    float3 N = gnrm[gid].xyz, T = gtan[gid].xyz; \
    float3 B = cross(N, T) * (gtan[gid].w < 0.0f ? -1.0f : 1.0f), x = gpos[gid].xyz; \
    float2 uv = guv[gid]; \
    int8 ob = objs[gobj[gid]]; \
    __global const float *m = mats + OBJ_MAT(ob) * MAT_STRIDE; \
    int sv_ = m[MAT_BCTEX] >= 0.0f || m[MAT_MRTEX] >= 0.0f; \
    if (sv_) { \
        __global float *r_ = pxmat + gid * MAT_STRIDE; \
        gltf_pixel_record(m, r_, texels, texinfo, texaff, uv, gduv[gid], 1.0f); \
        m = r_; \
    } \
    float3 kd = mat3(m, MAT_KD), ks = mat3(m, MAT_KS); \
    int kdt_ = (int)m[MAT_KDTEX], kst_ = (int)m[MAT_KSTEX]; \
    if (kdt_ >= 0) kd *= tex_filtered(texels, texinfo[kdt_], texaff, kdt_, uv, gduv[gid]).xyz; \
    if (kst_ >= 0) ks *= tex_filtered(texels, texinfo[kst_], texaff, kst_, uv, gduv[gid]).xyz; \
    Vis vis; \
    vis_init(&vis, ob, OBJF_MAXD(objf[gobj[gid]]), gtri[gid], gbary[gid], vfaces, coeffs, \
             ssdf_data, !(flags & FLAG_NO_VISIBILITY))

#endif
