"""sgpipe: spherical-Gaussian precomputation, rendering and verification pipeline."""

__version__ = "0.1.0"
