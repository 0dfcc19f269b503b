"""SG / vMF / SH math core: pure numpy, no sgpipe imports (see docs/MATH.md)."""
from .fh import (FH_LAMBDA_RANGE, FH_THETA_RANGE, PUBLISHED_FH_COEFFS, REFIT_FH_COEFFS, fh_exact,
                 fh_hat_exact, fh_hat_sigmoid, fh_hemisphere, fh_k, fh_sigmoid, fh_sigmoid_ise,
                 refit_fh_sigmoid)
from .maps import (cubemap_dir, cubemap_solid_angles, cubemap_texel_dirs, dir_to_cubemap,
                   dir_to_dual_paraboloid, dir_to_latlong, dual_paraboloid_dir,
                   dual_paraboloid_distortion, dual_paraboloid_solid_angles,
                   dual_paraboloid_texel_dirs, dual_paraboloid_valid_mask, latlong_dir,
                   latlong_solid_angles, latlong_texel_dirs)
from .quadrature import (gauss_legendre, hemisphere_quadrature, integrate_sphere, lobe_quadrature,
                         sphere_quadrature)
from .rotation import (axis_angle_matrix, quat_from_to, quat_multiply, quat_rotate, quat_to_matrix,
                       rotation_between)
from .sg import (CLAMPED_COSINE_LAMBDA, CLAMPED_COSINE_MU, clamped_cosine_l2_error,
                 clamped_cosine_sg, fit_clamped_cosine_sg, sg_eval, sg_inner, sg_integral,
                 sg_product, sg_rotate, sg_sharpness_from_area, sg_support_area, sg_warp)
from .sh import sh_eval, sh_expand_bands, sh_index, sh_irradiance_coeffs, sh_project, sh_reconstruct
from .sphere import (concentric_square_to_hemisphere, concentric_texel_solid_angle,
                     fibonacci_sphere, hemisphere_to_concentric_square, icosahedral_geodesic,
                     tangent_frame, to_local, to_world)
from .vmf import kappa_from_rbar, mean_resultant_length, sg_to_vmf, vmf_pdf, vmf_to_sg

from types import ModuleType as _Mod

__all__ = [n for n, v in list(globals().items()) if not n.startswith("_") and not isinstance(v, _Mod)]
