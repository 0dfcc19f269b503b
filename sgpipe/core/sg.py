"""Stub (being filled in)."""
import numpy as np

CLAMPED_COSINE_LAMBDA = 2.133
CLAMPED_COSINE_MU = 1.170

def sg_eval(v, p, lam, mu):
    raise NotImplementedError


def sg_product(p1, lam1, mu1, p2, lam2, mu2):
    raise NotImplementedError


def sg_inner(p1, lam1, mu1, p2, lam2, mu2):
    raise NotImplementedError


def sg_integral(lam, mu):
    raise NotImplementedError


def sg_rotate(R, p):
    raise NotImplementedError


def sg_support_area(lam, eps=0.1):
    raise NotImplementedError


def sg_sharpness_from_area(area, eps=0.1):
    raise NotImplementedError


def sg_warp(p, lam, mu, o):
    raise NotImplementedError


def fit_clamped_cosine_sg():
    raise NotImplementedError


def clamped_cosine_sg(n):
    raise NotImplementedError


