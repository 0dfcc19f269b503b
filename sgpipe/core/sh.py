"""Stub (being filled in)."""
import numpy as np

def sh_eval(dirs, lmax):
    raise NotImplementedError


def sh_project(values, dirs, weights, lmax):
    raise NotImplementedError


def sh_irradiance_coeffs(lmax):
    raise NotImplementedError


