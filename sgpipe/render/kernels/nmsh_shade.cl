/* Method `nm_sh`: Han07 §5, eq 12 with the MIP-mapped SH NDF γ_lm and the BRDF ρ̂_l
 * (kernels/include/nm_shade.h, NM_FILTER = NM_SH). */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"
#include "nm_shade.h"
#define NM_FILTER NM_SH

__kernel void nmsh_shade(NMSH_SHADE_ARGS)
{
#include "nm_shade_body.h"
}
