"""Stub (being filled in)."""
import numpy as np

def fibonacci_sphere(n):
    raise NotImplementedError


def icosahedral_geodesic(freq=3):
    raise NotImplementedError


def concentric_square_to_hemisphere(u, v):
    raise NotImplementedError


def hemisphere_to_concentric_square(d):
    raise NotImplementedError


def concentric_texel_solid_angle(res):
    raise NotImplementedError


def tangent_frame(n, t_hint=None):
    raise NotImplementedError


def to_local(d, n, t, b):
    raise NotImplementedError


def to_world(d, n, t, b):
    raise NotImplementedError


