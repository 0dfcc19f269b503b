"""Lobe fitting: spherical EM (numba), Wang09 NDF SG fits (LM, L-BFGS-B), per-view vMF mixtures.

    from sgpipe.fit import spherical_em, fit_ndf_sg, fit_view_gmm
    mix = spherical_em(x, weights, n_lobes=8)          # Han07 Alg. 1 (+ eq 22, eq 23)
    sg = fit_ndf_sg(brdf.ndf_model, method="auto")      # Wang09 eq 12 / LM / L-BFGS-B
    gmm = fit_view_gmm(brdf, n_theta=16, n_lobes=8)     # Töral19 eq 3, per view o_j

The compiled EM core (`_em_jit.em_vmf`) is reusable by other stages (e.g. normal-map
filtering): weighted unit samples, optional per-sample feature vectors and neighbour lobes.
"""

from sgpipe.fit.em import VMFMixture, init_sort_split, spherical_em, spherical_em_batch
from sgpipe.fit.ndf_sg import NdfSG, analytic_ndf_sg, fit_ndf_sg, ndf_error_curve
from sgpipe.fit.view_gmm import ViewGMM, fit_view_gmm, interpolation_errors, lobe_curve

__all__ = ["VMFMixture", "init_sort_split", "spherical_em", "spherical_em_batch", "NdfSG",
           "analytic_ndf_sg", "fit_ndf_sg", "ndf_error_curve", "ViewGMM", "fit_view_gmm",
           "interpolation_errors", "lobe_curve"]
