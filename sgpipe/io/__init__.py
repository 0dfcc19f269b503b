"""Artifact store: EXR (OpenImageIO), deterministic NPZ, PNG previews, manifests, atomic writes."""

from sgpipe.io.atomic import atomic_path, file_hash
from sgpipe.io.exr import read_exr, write_exr
from sgpipe.io.npz import read_npz, write_npz
from sgpipe.io.png import read_data_image, tonemap_srgb, write_png

__all__ = ["atomic_path", "file_hash", "read_exr", "write_exr", "read_npz", "write_npz",
           "write_png", "tonemap_srgb", "read_data_image"]
