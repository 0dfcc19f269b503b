"""Stub (being filled in)."""
import numpy as np

PUBLISHED_FH_COEFFS = None
REFIT_FH_COEFFS = None

def fh_exact(theta_d, lam):
    raise NotImplementedError


def fh_sigmoid(theta_d, lam, coeffs=None):
    raise NotImplementedError


def refit_fh_sigmoid():
    raise NotImplementedError


