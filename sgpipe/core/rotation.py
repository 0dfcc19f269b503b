"""Stub (being filled in)."""
import numpy as np

def rotation_between(a, b):
    raise NotImplementedError


def quat_from_to(a, b):
    raise NotImplementedError


def quat_rotate(q, v):
    raise NotImplementedError


