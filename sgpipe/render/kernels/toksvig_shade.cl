/* Method `toksvig`: Han07 normal-map filtering under point / directional lights
 * (kernels/include/nm_shade.h; filter 2: 0 vMF mixture, 1 normalised MIP, 2 Toksvig). */
#include "sg.h"
#include "ssdf.h"
#include "cubemap.h"
#include "microfacet.h"
#include "shading.h"
#define NM_FILTER 2
#define NM_KERNEL toksvig_shade
#define NM_ARGS TOKSVIG_SHADE_ARGS
#include "nm_shade.h"
