/* Method `vmf`: Han07 normal-map filtering with the vMF mixture (Algorithm 2, eq 20–21, 24–26;
 * kernels/include/nm_shade.h, NM_FILTER = NM_VMF). */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"
#include "nm_shade.h"
#define NM_FILTER NM_VMF

__kernel void vmf_shade(VMF_SHADE_ARGS)
{
#include "nm_shade_body.h"
}
