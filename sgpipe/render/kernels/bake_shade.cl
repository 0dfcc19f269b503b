/* Method `engine_bake`: one lobe, κ from the MIP normal length, eq 20 or 21 (engine bake;
 * kernels/include/nm_shade.h, NM_FILTER = NM_BAKE). */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"
#include "nm_shade.h"
#define NM_FILTER NM_BAKE

__kernel void bake_shade(BAKE_SHADE_ARGS)
{
#include "nm_shade_body.h"
}
