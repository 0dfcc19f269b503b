"""DDS cubemaps with every mip (Microsoft "DDS programming guide": DDS_HEADER + the
DDS_HEADER_DXT10 extension), DXGI_FORMAT_R16G16B16A16_FLOAT, alpha 1.

Data order: for each face (+X −X +Y −Y +Z −Z, the array slices of a cube) all its mips from the
largest down, rows top to bottom — the same texels as the KTX2 file (sgpipe.export.ktx2), whose
first row is t = 0 of the OpenGL / Direct3D cube face table.
"""

from __future__ import annotations

import struct

import numpy as np

from sgpipe.export.packed_float import to_half_rgba

MAGIC = b"DDS "
DDSD_CAPS, DDSD_HEIGHT, DDSD_WIDTH, DDSD_PITCH = 0x1, 0x2, 0x4, 0x8
DDSD_PIXELFORMAT, DDSD_MIPMAPCOUNT = 0x1000, 0x20000
DDPF_FOURCC = 0x4
DDSCAPS_COMPLEX, DDSCAPS_TEXTURE, DDSCAPS_MIPMAP = 0x8, 0x1000, 0x400000
DDSCAPS2_CUBEMAP = 0x200
DDSCAPS2_ALL_FACES = 0xFC00          # POSITIVEX … NEGATIVEZ
DXGI_FORMAT_R16G16B16A16_FLOAT = 10
DXGI_FORMAT_R8G8B8A8_UNORM = 28      # the container check: OpenImageIO 3.2 reads no float DXGI
DXGI_FORMAT_R16_FLOAT = 54
D3D10_RESOURCE_DIMENSION_TEXTURE2D = 3
DDS_RESOURCE_MISC_TEXTURECUBE = 0x4
DDS_ALPHA_MODE_STRAIGHT = 1
TEXEL_BYTES = {DXGI_FORMAT_R16G16B16A16_FLOAT: 8, DXGI_FORMAT_R8G8B8A8_UNORM: 4,
               DXGI_FORMAT_R16_FLOAT: 2}


def header_bytes(size: int, levels: int, dxgi: int = DXGI_FORMAT_R16G16B16A16_FLOAT,
                 cube: bool = True) -> bytes:
    """Magic, the 124-byte DDS_HEADER and the 20-byte DDS_HEADER_DXT10 of a cube of face
    `size` (or a square 2-D texture) with `levels` mips."""
    flags = (DDSD_CAPS | DDSD_HEIGHT | DDSD_WIDTH | DDSD_PITCH | DDSD_PIXELFORMAT
             | DDSD_MIPMAPCOUNT)
    pixel_format = struct.pack("<II4s5I", 32, DDPF_FOURCC, b"DX10", 0, 0, 0, 0, 0)
    head = struct.pack("<7I", 124, flags, size, size, size * TEXEL_BYTES[dxgi], 0, levels)
    head += b"\0" * 44                                   # dwReserved1[11]
    head += pixel_format
    head += struct.pack("<5I", DDSCAPS_COMPLEX | DDSCAPS_TEXTURE | DDSCAPS_MIPMAP,
                        DDSCAPS2_CUBEMAP | DDSCAPS2_ALL_FACES if cube else 0, 0, 0, 0)
    dx10 = struct.pack("<5I", dxgi, D3D10_RESOURCE_DIMENSION_TEXTURE2D,
                       DDS_RESOURCE_MISC_TEXTURECUBE if cube else 0, 1, DDS_ALPHA_MODE_STRAIGHT)
    return MAGIC + head + dx10


def texels(faces: np.ndarray, dxgi: int) -> np.ndarray:
    """(…, n, n, C) → the stored texels: float16 RGBA (RGB gets alpha 1), float16 R (the first
    channel), or for R8G8B8A8_UNORM round(255·clamp(x, 0, 1)) RGBA (alpha 255; values, not an
    sRGB encoding)."""
    if dxgi == DXGI_FORMAT_R16G16B16A16_FLOAT:
        if faces.shape[-1] == 4:
            return np.clip(np.asarray(faces, np.float64), -65504.0, 65504.0).astype("<f2")
        return to_half_rgba(faces).astype("<f2")
    if dxgi == DXGI_FORMAT_R16_FLOAT:
        return np.clip(np.asarray(faces, np.float64)[..., :1], -65504.0, 65504.0).astype("<f2")
    if dxgi == DXGI_FORMAT_R8G8B8A8_UNORM:
        q = np.rint(255.0 * np.clip(np.asarray(faces, float), 0.0, 1.0))
        return np.concatenate([q, np.full(q.shape[:-1] + (1,), 255.0)], -1).astype(np.uint8)
    raise ValueError(f"unsupported DXGI format {dxgi}")


def write_dds(levels: list[np.ndarray], dxgi: int = DXGI_FORMAT_R16G16B16A16_FLOAT, *,
              cube: bool = True) -> bytes:
    """The DDS file of a mip chain (largest first) of (6, n_m, n_m, C) cubemaps or
    (cube=False) (n_m, n_m, C) textures."""
    data = [texels(lv if cube else lv[None], dxgi) for lv in levels]
    faces = 6 if cube else 1
    body = b"".join(data[m][f].tobytes() for f in range(faces) for m in range(len(levels)))
    return header_bytes(levels[0].shape[1], len(levels), dxgi, cube) + body


def read_dds(buf: bytes) -> dict:
    """The header fields and the levels (F, n, n, C) float64 of a file written by write_dds
    (F = 6 for a cube, else 1)."""
    if buf[:4] != MAGIC:
        raise ValueError("not a DDS file")
    size, flags, height, width, pitch, depth, mips = struct.unpack_from("<7I", buf, 4)
    fourcc = buf[4 + 72 + 8:4 + 72 + 12]
    caps = struct.unpack_from("<4I", buf, 4 + 104)
    dx10 = struct.unpack_from("<5I", buf, 128)
    faces = 6 if caps[1] & DDSCAPS2_CUBEMAP else 1
    dtype, chans = {DXGI_FORMAT_R16G16B16A16_FLOAT: ("<f2", 4), DXGI_FORMAT_R16_FLOAT: ("<f2", 1),
                    DXGI_FORMAT_R8G8B8A8_UNORM: ("u1", 4)}[dx10[0]]
    pos = 148
    levels = [np.zeros((faces, max(width >> m, 1), max(width >> m, 1), chans))
              for m in range(mips)]
    for f in range(faces):
        for m in range(mips):
            n = max(width >> m, 1)
            count = n * n * chans
            levels[m][f] = np.frombuffer(buf, dtype, count, pos).reshape(n, n, chans)
            pos += np.dtype(dtype).itemsize * count
    return {"size": size, "flags": flags, "height": height, "width": width, "pitch": pitch,
            "depth": depth, "mip_count": mips, "fourcc": fourcc, "caps": caps, "dx10": dx10,
            "levels": levels, "end": pos}
