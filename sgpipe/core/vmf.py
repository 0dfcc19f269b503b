"""Stub (being filled in)."""
import numpy as np

def vmf_pdf(x, mu, kappa):
    raise NotImplementedError


def mean_resultant_length(kappa):
    raise NotImplementedError


def kappa_from_rbar(rbar):
    raise NotImplementedError


def sg_to_vmf(lam, mu):
    raise NotImplementedError


def vmf_to_sg(kappa, weight):
    raise NotImplementedError


