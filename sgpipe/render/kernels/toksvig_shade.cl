/* Method `toksvig`: Toksvig's exponent (roughness) from the MIP normal length (baseline;
 * kernels/include/nm_shade.h, NM_FILTER = NM_TOKSVIG). */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"
#include "nm_shade.h"
#define NM_FILTER NM_TOKSVIG

__kernel void toksvig_shade(TOKSVIG_SHADE_ARGS)
{
#include "nm_shade_body.h"
}
