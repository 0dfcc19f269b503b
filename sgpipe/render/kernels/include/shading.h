/* Per-pixel shading inputs shared by the sg, gmm and fis kernels: G-buffer records, object
 * records, textures (kd / ks / normal maps), SSDF coefficient interpolation, local lights. */
#ifndef SGPIPE_SHADING_H
#define SGPIPE_SHADING_H

#include "records.h"   /* OBJ_*(ob), OBJF_*(of), FLAG_* (generated: sgpipe/render/records.py) */
#include "methods.h"   /* <KERNEL>_ARGS (generated: sgpipe/render/methods.py) */

/* Texture record int4: texel offset into the float4 texel buffer, width, height, unused.
 * UV convention (OBJ): v = 0 is the BOTTOM row; addressing wraps (repeat). */
inline float4 tex_bilinear(__global const float4 *texels, int4 info, float2 uv) {
    int w = info.y, h = info.z;
    float x = (uv.x - floor(uv.x)) * (float)w - 0.5f;
    float vv = 1.0f - (uv.y - floor(uv.y));
    float y = vv * (float)h - 0.5f;
    float x0f = floor(x), y0f = floor(y);
    float fx = x - x0f, fy = y - y0f;
    int x0 = ((int)x0f % w + w) % w, y0 = ((int)y0f % h + h) % h;
    int x1 = (x0 + 1) % w, y1 = (y0 + 1) % h;
    __global const float4 *t = texels + info.x;
    float4 a = mix(t[y0 * w + x0], t[y0 * w + x1], fx);
    float4 b = mix(t[y1 * w + x0], t[y1 * w + x1], fx);
    return mix(a, b, fy);
}

/* Texel index i wrapped into [0, n): mode 0 repeat, 1 clamp to edge, 2 mirrored repeat. */
inline int tex_wrap(int i, int n, int mode) {
    if (mode == 1) return clamp(i, 0, n - 1);
    if (mode == 2) { int p = ((i % (2 * n)) + 2 * n) % (2 * n); return p < n ? p : 2 * n - 1 - p; }
    return ((i % n) + n) % n;
}

/* The 2 × 2 texels a bilinear read at glTF texture coordinates (s, t) mixes on a w × h level
 * with the record's wrap modes: their columns x0, x1 and rows y0, y1 in *q, the fractions
 * (fx, fy) returned. */
inline float2 tex_corners(int4 info, int w, int h, float2 st, int4 *q) {
    int ws = (info.w >> 8) & 3, wt = (info.w >> 10) & 3;
    float x = st.x * (float)w - 0.5f, y = st.y * (float)h - 0.5f;
    float x0f = floor(x), y0f = floor(y);
    *q = (int4)(tex_wrap((int)x0f, w, ws), tex_wrap((int)x0f + 1, w, ws),
                tex_wrap((int)y0f, h, wt), tex_wrap((int)y0f + 1, h, wt));
    return (float2)(x - x0f, y - y0f);
}

/* Bilinear between texel centres of MIP level `lv` (render.textures: level l is
 * max(1, w >> l) × max(1, h >> l), stored after level l − 1, rows top to bottom) at glTF
 * texture coordinates (s, t) (t = 0 the top row), the record's wrap modes. */
inline float4 tex_level(__global const float4 *texels, int4 info, int lv, float2 st) {
    int w = info.y, h = info.z, off = info.x;
    for (int l = 0; l < lv; ++l) { off += w * h; w = max(w >> 1, 1); h = max(h >> 1, 1); }
    int4 q;
    float2 f = tex_corners(info, w, h, st, &q);
    __global const float4 *t = texels + off;
    float4 a = mix(t[q.z * w + q.x], t[q.z * w + q.y], f.x);
    float4 b = mix(t[q.w * w + q.x], t[q.w * w + q.y], f.x);
    return mix(a, b, f.y);
}

/* Bilinear taps per footprint axis at most: a footprint longer than this many texels reads
 * the MIP level where it is not (tap spacing about one texel of that level). */
#define TEX_BOX_TAPS 4

/* The taps averaging a texture at OBJ uv (v = 0 the bottom row) over the pixel's footprint:
 * the glTF texture transform (aff, rows of its 3×3 matrix on (s, t) = (u, 1 − v); aff[0].w =
 * 0: none), then the parallelogram the pixel's box covers, uv ± ½ (∂uv/∂x) ± ½ (∂uv/∂y)
 * (duv = (∂u/∂x, ∂v/∂x, ∂u/∂y, ∂v/∂y), scene.footprint), read as n_x × n_y bilinear taps at the centres of
 * an n_x × n_y grid over it — the reference's box pixel filter over the texture — at the
 * finest MIP level where neither side needs more than TEX_BOX_TAPS taps of one texel (the
 * level returned; the centre and sides in (s, t) and the taps per side written). A footprint
 * under a texel is one bilinear tap of level 0. */
inline int tex_grid(int4 info, __global const float4 *texaff, int k, float2 uv, float4 duv,
                    float2 *st_, float2 *dx_, float2 *dy_, int *nx_, int *ny_) {
    float2 st = (float2)(uv.x, 1.0f - uv.y);
    float2 dx = (float2)(duv.x, -duv.y), dy = (float2)(duv.z, -duv.w);
    float4 a0 = texaff[2 * k], a1 = texaff[2 * k + 1];
    if (a0.w != 0.0f) {
        st = (float2)(a0.x * st.x + a0.y * st.y + a0.z, a1.x * st.x + a1.y * st.y + a1.z);
        dx = (float2)(a0.x * dx.x + a0.y * dx.y, a1.x * dx.x + a1.y * dx.y);
        dy = (float2)(a0.x * dy.x + a0.y * dy.y, a1.x * dy.x + a1.y * dy.y);
    }
    int levels = info.w & 255;
    float2 sz = (float2)((float)info.y, (float)info.z);
    float lx = length(dx * sz), ly = length(dy * sz);     /* the sides in level-0 texels */
    float need = fmax(lx, ly) / (float)TEX_BOX_TAPS;
    int lv = need > 1.0f ? min((int)ceil(log2(need)), levels - 1) : 0;
    float scale = 1.0f / (float)(1 << lv);
    *nx_ = clamp((int)ceil(lx * scale - 1e-3f), 1, TEX_BOX_TAPS);
    *ny_ = clamp((int)ceil(ly * scale - 1e-3f), 1, TEX_BOX_TAPS);
    *st_ = st; *dx_ = dx; *dy_ = dy;
    return lv;
}

/* Tap (i, j) of tex_grid's n_x × n_y taps: the centre of its cell of the footprint. */
inline float2 tex_tap(float2 st, float2 dx, float2 dy, int i, int j, int nx, int ny) {
    return st + (((float)i + 0.5f) / (float)nx - 0.5f) * dx
              + (((float)j + 0.5f) / (float)ny - 0.5f) * dy;
}

/* tex_grid's taps averaged: the texture over the footprint. */
inline float4 tex_filtered(__global const float4 *texels, int4 info,
                           __global const float4 *texaff, int k, float2 uv, float4 duv) {
    float2 st, dx, dy;
    int nx, ny;
    int lv = tex_grid(info, texaff, k, uv, duv, &st, &dx, &dy, &nx, &ny);
    float4 c = (float4)(0.0f);
    for (int j = 0; j < ny; ++j)
        for (int i = 0; i < nx; ++i)
            c += tex_level(texels, info, lv, tex_tap(st, dx, dy, i, j, nx, ny));
    return c / (float)(nx * ny);
}

/* Shortest-arc quaternion (x, y, z, w) taking +z to the unit vector n (n.z > −1). */
inline float4 quat_from_z(float3 n) {
    float4 q = (float4)(-n.y, n.x, 0.0f, 1.0f + n.z);
    float l = length(q);
    return l > 1e-8f ? q / l : (float4)(1.0f, 0.0f, 0.0f, 0.0f);
}
inline float4 quat_conj(float4 q) { return (float4)(-q.x, -q.y, -q.z, q.w); }
/* Hamilton product a ⊗ b (x, y, z, w): rotate by b, then by a. */
inline float4 quat_mul(float4 a, float4 b) {
    return (float4)(a.w * b.xyz + b.w * a.xyz + cross(a.xyz, b.xyz),
                    a.w * b.w - dot(a.xyz, b.xyz));
}

/* Tangent-space normal (texture RGB n·0.5 + 0.5, z up, green = +v) → unit local normal. */
inline float3 normal_from_map(float4 c) {
    float3 n = 2.0f * c.xyz - 1.0f;
    n.z = fmax(n.z, 1e-3f);
    return normalize(n);
}

/* Local light record (float4 ×2): (position or direction-to-light, type 0 point / 1 directional),
 * (RGB intensity, radius). Wang09 eq 32–33 with energy-matched amplitude: the lobe integrates to
 * the light's irradiance at normal incidence (point: I/d², directional: E). */
inline SG light_sg(float4 a, float4 b, float3 x) {
    float3 dir;
    float area, irr_scale;
    if (a.w < 0.5f) {
        float3 d = a.xyz - x;
        float d2 = fmax(dot(d, d), 1e-12f);
        dir = d * rsqrt(d2);
        area = SG_TWO_PI * b.w * b.w / d2;
        irr_scale = 1.0f / d2;
    } else {
        dir = normalize(a.xyz);
        area = SG_TWO_PI * b.w * b.w;
        irr_scale = 1.0f;
    }
    /* float32 keeps e^{d − λ1 − λ2} accurate to ~1e-3 up to λ ≈ 2e4 (0.4° lobes). */
    float lam = area > 0.0f ? fmin(sg_lambda_from_area(area), 2e4f) : 2e4f;
    return sg_make(dir, lam, b.xyz * (irr_scale / sg_integral_unit(lam)));
}

/* Lift a local direction to at least elevation asin(zmin) (keeps M_o and f_d finite and
 * continuous for lobe axes at or below the horizon of the BRDF frame). */
inline float3 lift(float3 d, float zmin) {
    if (d.z >= zmin) return d;
    float2 xy = d.xy;
    float l = length(xy);
    xy = l > 1e-8f ? xy / l : (float2)(1.0f, 0.0f);
    float r = sqrt(1.0f - zmin * zmin);
    return (float3)(xy * r, zmin);
}

/* Per-pixel SSDF state: interpolated PCA coefficients of the object's SSDF mesh (eq 24). */
typedef struct {
    int has;
    int res;
    float maxd;
    __global const float *basis;
    __global const float *mean;
    ssdf_vec w[SSDF_NW];
} Vis;

inline void vis_init(Vis *v, int8 ob, float maxd, int tri, float2 bc,
                     __global const int *vfaces, __global const float *coeffs,
                     __global const float *ssdf_data, int enabled) {
    v->has = 0; v->res = 1; v->maxd = 1.5707963f;
    v->basis = ssdf_data; v->mean = ssdf_data;
#if NV > 0
    if (enabled && OBJ_HAS_SSDF(ob) && tri >= 0) {
        v->has = 1; v->res = OBJ_RES(ob); v->maxd = maxd;
        v->basis = ssdf_data + OBJ_BASIS(ob); v->mean = ssdf_data + OBJ_MEAN(ob);
        __global const int *f = vfaces + 3 * (OBJ_FACE0(ob) + tri);
        float w0 = 1.0f - bc.x - bc.y;
        __global const float *c0 = coeffs + (OBJ_VERT0(ob) + f[0]) * NV;
        __global const float *c1 = coeffs + (OBJ_VERT0(ob) + f[1]) * NV;
        __global const float *c2 = coeffs + (OBJ_VERT0(ob) + f[2]) * NV;
        for (int j = 0; j < SSDF_NW; ++j)
            v->w[j] = w0 * ssdf_vload(j, c0) + bc.x * ssdf_vload(j, c1)
                      + bc.y * ssdf_vload(j, c2);
    }
#endif
}

/* θ_d of the SSDF at a direction of the geometric local frame, clamped to ±min(maxd, π/2)
 * (docs/ARTIFACTS.md visibility/, decoding steps 2–4 and products). */
inline float vis_theta(const Vis *v, float3 d) {
#if NV > 0
    float th = ssdf_theta(v->has, v->basis, v->mean, v->res, v->w, d);
#else
    float th = asin(clamp(d.z, -1.0f, 1.0f));
#endif
    float lim = fmin(v->maxd, 1.5707963f);
    return clamp(th, -lim, lim);
}

/* Per-pixel set-up shared by sg, gmm and fis: the G-buffer frame (n, t, b = n × t), the
 * material with its texture scales (SVBRDF), and the normal-map rotation q of the local frame
 * (§7) with the view direction o' in the rotated frame. Visibility stays in the geometric one. */
typedef struct {
    float3 N, T, B, x, kd, ks, op;
    float2 uv;
    int8 ob;
    __global const float *m;
    float4 q, qi;
} Pixel;

#include "gltf_record.h"   /* gltf_pixel_record, gltf_filtered_params */

inline Pixel pixel_init(int gid, __global const float4 *gnrm, __global const float4 *gtan,
                        __global const float4 *gview, __global const float4 *gpos,
                        __global const float2 *guv, __global const int *gobj,
                        __global const int8 *objs, __global const float *mats,
                        __global const float4 *texels, __global const int4 *texinfo,
                        __global const float4 *texaff, __global const float4 *gduv,
                        __global float *pxmat) {
    Pixel p;
    p.N = gnrm[gid].xyz;
    p.T = gtan[gid].xyz;
    p.B = cross(p.N, p.T);
    p.x = gpos[gid].xyz;
    p.ob = objs[gobj[gid]];
    p.m = mats + OBJ_MAT(p.ob) * MAT_STRIDE;
    p.uv = guv[gid];
    float4 duv = gduv[gid];
    /* KHR_materials_anisotropy's texture, footprint-filtered: its direction (RG) turns the
     * BRDF frame (below), its strength (B) scales the factor's in the pixel's record */
    int at = (int)p.m[MAT_ANTEX];
    float4 ac = at >= 0 ? tex_filtered(texels, texinfo[at], texaff, at, p.uv, duv)
                        : (float4)(1.0f, 0.5f, 1.0f, 0.0f);
    if (p.m[MAT_BCTEX] >= 0.0f || p.m[MAT_MRTEX] >= 0.0f || at >= 0) {
        __global float *r = pxmat + gid * MAT_STRIDE;
        gltf_pixel_record(p.m, r, texels, texinfo, texaff, p.uv, duv, ac.z);
        p.m = r;
    }
    p.kd = mat3(p.m, MAT_KD);
    p.ks = mat3(p.m, MAT_KS);
    int kt = (int)p.m[MAT_KDTEX], st = (int)p.m[MAT_KSTEX];
    if (kt >= 0) p.kd *= tex_filtered(texels, texinfo[kt], texaff, kt, p.uv, duv).xyz;
    if (st >= 0) p.ks *= tex_filtered(texels, texinfo[st], texaff, st, p.uv, duv).xyz;
    p.q = (float4)(0.0f, 0.0f, 0.0f, 1.0f);
    int nm = OBJ_NMAP(p.ob);
    if (nm >= 0) {
        /* a glTF normal texture keeps its sampler and transform (one bilinear tap of level
         * 0); its +Y runs along w (n × t), w the tangent's handedness */
        float4 c = (texinfo[nm].w >> 8) != 0 || texaff[2 * nm].w != 0.0f
                   ? tex_filtered(texels, texinfo[nm], texaff, nm, p.uv, (float4)(0.0f))
                   : tex_bilinear(texels, texinfo[nm], p.uv);
        if (gtan[gid].w < 0.0f) c.y = 1.0f - c.y;
        p.q = quat_from_z(normal_from_map(c));
    }
    /* the anisotropy direction (MAT_AROT): the BRDF frame turned about the (mapped) normal,
     * from the tangent towards the bitangent of the tangent's handedness (glTF's bitangent
     * is w · n × t) */
    float rot = p.m[MAT_AROT];
    if (at >= 0) {
        float2 d = 2.0f * ac.xy - 1.0f;
        if (dot(d, d) > 1e-12f) rot += atan2(d.y, d.x);
    }
    if (rot != 0.0f) {
        float h = 0.5f * (gtan[gid].w < 0.0f ? -rot : rot);
        p.q = quat_mul(p.q, (float4)(0.0f, 0.0f, sin(h), cos(h)));
    }
    p.qi = quat_conj(p.q);
    float3 ol = lift(to_local(gview[gid].xyz, p.T, p.B, p.N), 0.01f);
    p.op = lift(normalize(quat_rotate(p.qi, ol)), 0.01f);
    return p;
}

/* The prologue of every shading kernel (parameters <KERNEL>_ARGS): threads past n return; the
 * pixel's set-up (pixel_init) as locals N, T, B, x, kd, ks, op, q, qi, ob, m; its SSDF state
 * `vis` (PCA coefficients interpolated over the SSDF mesh triangle, eq 24), off under
 * FLAG_NO_VISIBILITY. */
#define SHADE_PIXEL_PROLOGUE \
    int gid = get_global_id(0); \
    if (gid >= n) return; \
    Pixel px = pixel_init(gid, gnrm, gtan, gview, gpos, guv, gobj, objs, mats, texels, texinfo, \
                          texaff, gduv, pxmat); \
    float3 N = px.N, T = px.T, B = px.B, x = px.x, kd = px.kd, ks = px.ks, op = px.op; \
    float4 q = px.q, qi = px.qi; \
    int8 ob = px.ob; \
    __global const float *m = px.m; \
    Vis vis; \
    vis_init(&vis, ob, OBJF_MAXD(objf[gobj[gid]]), gtri[gid], gbary[gid], vfaces, coeffs, \
             ssdf_data, !(flags & FLAG_NO_VISIBILITY))

/* Lobes at least this sharp are treated as small lights: their product with the broad
 * clamped-cosine SG C* (λ = 2.133, peak 1.17) is replaced by its sharp limit
 * E·max(0, n·l)·f̂_h(θ_d(l), λ). C*'s shape error is ±17 % at a single direction (−18 % at
 * 55° from n), which a dominant small source (a sun) would carry straight into the image. */
#ifndef SHARP_LIGHT
#define SHARP_LIGHT 64.0f
#endif

/* The sharpness given a delta direction (the environment's point set) for the SSDF horizon f̂_h. */
#define POINT_LAMBDA 2e4f

/* The environment's point set (a sun) through the exact specular BRDF M_o(i) D(h) (the
 * material's NDF table, ndf = (offset, nt, np, has)) with each point's SSDF horizon
 * f̂_h(θ_d, POINT_LAMBDA), × env_scale: a delta light needs ρ at one direction, and a lobe's
 * Gaussian fall-off loses GGX's power-law tail, which a sun 10⁴× the sky lifts above white far
 * from the highlight. op: the view in the normal-mapped local frame, qi its rotation. */
inline float3 points_exact_specular(__global const float4 *pts, int n_pts,
                                    __global const float *m, __global const float *tables,
                                    int4 ndf, float3 ks, float3 op, float4 qi,
                                    float3 T, float3 B, float3 N, const Vis *vis,
                                    float env_scale) {
    float3 rs = (float3)(0.0f);
    for (int k = 0; k < n_pts; ++k) {
        float3 lg = to_local(pts[2 * k].xyz, T, B, N);
        float3 lp = quat_rotate(qi, lg);
        if (lp.z <= 0.0f || lg.z <= 0.0f) continue;
        float3 h = normalize(op + lp);
        rs += (env_scale * lp.z * ndf_exact(m, tables, ndf, h)
               * fh_hat(vis_theta(vis, lg), POINT_LAMBDA))
              * mf_M(m, tables, ks, op, lp) * pts[2 * k + 1].xyz;
    }
    return rs;
}

/* A sharp light's specular part with the exact BRDF: E · M_o(l) D(h) (the material's NDF
 * table), E its shadowed irradiance (sg_light_diffuse), o and l in the normal-mapped frame. */
inline float3 sharp_light_specular(float3 E, __global const float *m,
                                   __global const float *tables, int4 ndf, float3 ks, float3 o,
                                   float3 l) {
    return E * mf_M(m, tables, ks, o, l) * ndf_exact(m, tables, ndf, normalize(o + l));
}

/* One SG light L (local frame) through the diffuse side of Wang09 eq 39 / 42 with the SSDF
 * visibility, to be multiplied by f_d at *fdir: a light at least SHARP_LIGHT sharp as its limit
 * ∫L · max(0, n′·l) · f̂_h(θ_d(l), λ) (n′ the normal-mapped normal: l′ = qi·l, *fdir = l′), a
 * broader one as (C* ⊗ L) · V^d with cosg the normal-mapped C* (*fdir: its lifted axis). */
inline float3 sg_light_diffuse(SG L, SG cosg, float4 qi, const Vis *vis, float3 *fdir) {
    if (L.lam >= SHARP_LIGHT) {
        float3 lp = quat_rotate(qi, L.p);
        *fdir = lp;
        if (lp.z > 0.0f && L.p.z > 0.0f)
            return sg_integral(L) * (lp.z * fh_hat(vis_theta(vis, L.p), L.lam));
        return (float3)(0.0f);
    }
    SG g = sg_product(cosg, L);
    *fdir = lift(quat_rotate(qi, g.p), 0.05f);
    return sg_dot_visibility(g, vis_theta(vis, g.p));
}

#include "env_diffuse.h"

/* Wang09 eq 39 with the environment's SG light fit, as one sum: Σ_k f_d · (C* ⊗ L*_k) · V^d
 * (sharp lobes: see SHARP_LIGHT). Used by sg, and by gmm and fis for their diffuse term (as
 * Colbert & Křivánek use an irradiance map). Eight lobes at a time (env_diffuse.h); under
 * ENV_DIFFUSE_PER_LOBE one lobe at a time through sg_light_diffuse, the form the lanes are
 * tested against. */
inline float3 diffuse_env_sg(__global const float *m, float3 kd, float3 op, float4 q, float4 qi,
                             float3 T, float3 B, float3 N, __global const float4 *env_sg,
                             int n_env_sg, float env_scale, const Vis *vis) {
#ifndef ENV_DIFFUSE_PER_LOBE
    return diffuse_env_sg8(m, kd, op, q, qi, T, B, N, env_sg, n_env_sg, env_scale, vis);
#else
    SG cosg = sg_clamped_cosine(quat_rotate(q, (float3)(0.0f, 0.0f, 1.0f)));
    float3 acc = (float3)(0.0f);
    for (int k = 0; k < n_env_sg; ++k) {
        float4 a = env_sg[2 * k], b = env_sg[2 * k + 1];
        SG L = sg_make(to_local(a.xyz, T, B, N), a.w, b.xyz * env_scale);
        float3 fdir;
        float3 E = sg_light_diffuse(L, cosg, qi, vis, &fdir);
        acc += mf_diffuse(m, kd, op, fdir) * E;
    }
    return acc;
#endif
}

#endif
