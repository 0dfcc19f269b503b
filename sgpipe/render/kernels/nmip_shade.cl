/* Method `normals_mip`: the normalised MIP of the normals, the plain BRDF (Han07 baseline;
 * kernels/include/nm_shade.h, NM_FILTER = NM_MIP). */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"
#include "nm_shade.h"
#define NM_FILTER NM_MIP

__kernel void nmip_shade(NMIP_SHADE_ARGS)
{
#include "nm_shade_body.h"
}
