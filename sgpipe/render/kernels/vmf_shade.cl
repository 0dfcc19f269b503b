/* Method `vmf`: Han07 normal-map filtering under point / directional lights
 * (kernels/include/nm_shade.h; NM_FILTER 0: 0 vMF mixture, 1 normalised MIP, 2 Toksvig). */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"
#include "nm_shade.h"
#define NM_FILTER 0

__kernel void vmf_shade(VMF_SHADE_ARGS)
{
#include "nm_shade_body.h"
}
