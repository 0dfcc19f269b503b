"""Stub (being filled in)."""
import numpy as np

def sphere_quadrature(n_theta, n_phi):
    raise NotImplementedError


def hemisphere_quadrature(n_theta, n_phi):
    raise NotImplementedError


def integrate_sphere(f, n=64):
    raise NotImplementedError


