"""Environment stage algorithms: map conversions, the SG-prefiltered Γ_L pyramid (Wang09
eq 34–35), Töral19's lobe-sized MIP lookups and FIS lod, SG / SH light fits."""
from sgpipe.envmap.maps import (cubemap_to_dual_paraboloid, cubemap_to_latlong,
                                dual_paraboloid_to_cubemap, latlong_to_cubemap, read_environment,
                                sample_cubemap, sample_dual_paraboloid)
from sgpipe.envmap.mip import MipChain, build_cube_chain, build_dp_chain, lobe_solid_angle
from sgpipe.envmap.store import load_light_fits, load_mip_chain, load_pyramid
from sgpipe.envmap.pyramid import Pyramid, PyramidSettings, build_pyramid, pyramid_levels

__all__ = ["cubemap_to_dual_paraboloid", "cubemap_to_latlong", "dual_paraboloid_to_cubemap",
           "latlong_to_cubemap", "read_environment", "sample_cubemap", "sample_dual_paraboloid",
           "MipChain", "build_cube_chain", "build_dp_chain", "lobe_solid_angle", "Pyramid",
           "PyramidSettings", "build_pyramid", "pyramid_levels", "load_pyramid",
           "load_mip_chain", "load_light_fits"]
