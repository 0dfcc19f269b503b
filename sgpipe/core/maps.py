"""Stub (being filled in)."""
import numpy as np

def latlong_dir(u, v):
    raise NotImplementedError


def dir_to_latlong(d):
    raise NotImplementedError


def latlong_texel_dirs(h, w):
    raise NotImplementedError


def latlong_solid_angles(h, w):
    raise NotImplementedError


def cubemap_dir(face, s, t):
    raise NotImplementedError


def dir_to_cubemap(d):
    raise NotImplementedError


def cubemap_texel_dirs(res):
    raise NotImplementedError


def cubemap_solid_angles(res):
    raise NotImplementedError


def dual_paraboloid_dir(hemi, s, t, b=1.0):
    raise NotImplementedError


def dir_to_dual_paraboloid(d, b=1.0):
    raise NotImplementedError


def dual_paraboloid_solid_angles(res, b=1.0):
    raise NotImplementedError


