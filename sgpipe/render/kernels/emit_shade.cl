/* Emitted radiance of each pixel's surface: a gltf_pbr material's `emissive` times its emissive
 * texture (sRGB-decoded at load) averaged over the pixel's footprint, as the base colour is
 * (shading.h tex_filtered). The render stage adds it to every OpenCL method's image; emission
 * lights nothing else. */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"

__kernel void emit_shade(EMIT_SHADE_ARGS) {
    int gid = get_global_id(0);
    if (gid >= n) return;
    Pixel px = pixel_init(gid, gnrm, gtan, gview, gpos, guv, gobj, objs, mats, texels, texinfo,
                          texaff, gduv, pxmat);
    float3 e = mat3(px.m, MAT_EMIT);
    int et = (int)px.m[MAT_EMTEX];
    if (et >= 0) e *= tex_filtered(texels, texinfo[et], texaff, et, px.uv, gduv[gid]).xyz;
    out[gid] = (float4)(e, 1.0f);
}
