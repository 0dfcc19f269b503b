"""KTX 2.0 cubemaps with a full mip chain, written to the Khronos KTX 2.0 specification
(identifier, header, index, level index, Data Format Descriptor, key/value data, level data
smallest level first), and a reader that parses every field back (the tests' proof).

Formats: VK_FORMAT_R16G16B16A16_SFLOAT (97, alpha 1), VK_FORMAT_R32G32B32A32_SFLOAT (109),
VK_FORMAT_B10G11R11_UFLOAT_PACK32 (122, sgpipe.export.packed_float), VK_FORMAT_R16_SFLOAT (76),
and the 8-bit VK_FORMAT_R8G8B8A8_UNORM (37) and _SRGB (43) (values clamped to [0, 1]; the sRGB
one encodes RGB with the sRGB curve, alpha linear). Any other vkFormat is refused by name. Faces +X −X +Y −Y +Z −Z in sgpipe's (OpenGL) cube
convention: texel row r, column c of face f at s = (c + ½)/n, t = (r + ½)/n, the first row in
the file at t = 0 — what Vulkan and OpenGL sample for direction d, and KTXorientation "rd".
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

import numpy as np

from sgpipe.export.packed_float import pack_b10g11r11, to_half_rgba, unpack_b10g11r11
from sgpipe.io.png import linear_to_srgb, srgb_to_linear

IDENTIFIER = bytes([0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A, 0x0A])
HEADER_BYTES = 80                    # identifier 12 + 9 × u32 + index 4 × u32 + 2 × u64
LEVEL_INDEX_ENTRY = 24               # byteOffset, byteLength, uncompressedByteLength (u64)

# Khronos Data Format (khr_df.h) constants used by the basic descriptor block
KHR_DF_MODEL_RGBSDA = 1
KHR_DF_PRIMARIES_BT709 = 1
KHR_DF_TRANSFER_LINEAR = 1
KHR_DF_TRANSFER_SRGB = 2
KHR_DF_VERSION = 2
CHANNEL_R, CHANNEL_G, CHANNEL_B, CHANNEL_A = 0, 1, 2, 15
QUAL_FLOAT, QUAL_SIGNED = 0x80, 0x40      # sample datatype qualifiers (high bits of the id)
QUAL_LINEAR = 0x10                         # a linear channel (alpha) in an sRGB format
F32_ONE, F32_MINUS_ONE, F32_ZERO = 0x3F800000, 0xBF800000, 0x00000000


@dataclass(frozen=True)
class KtxFormat:
    """A vkFormat: its number, typeSize, texel bytes and DFD samples
    (bitOffset, bitLength, channel | qualifiers, sampleLower, sampleUpper)."""

    name: str
    vk_format: int
    type_size: int
    texel_bytes: int
    samples: tuple
    transfer: int = KHR_DF_TRANSFER_LINEAR

    @property
    def alignment(self) -> int:
        """lcm(texel block size, 4): where each level's data must start."""
        return int(np.lcm(self.texel_bytes, 4))


RGBA16F = KtxFormat("R16G16B16A16_SFLOAT", 97, 2, 8, tuple(
    (16 * i, 16, ch | QUAL_FLOAT | QUAL_SIGNED, F32_MINUS_ONE, F32_ONE)
    for i, ch in enumerate((CHANNEL_R, CHANNEL_G, CHANNEL_B, CHANNEL_A))))
B10G11R11 = KtxFormat("B10G11R11_UFLOAT_PACK32", 122, 4, 4, (
    (0, 11, CHANNEL_R | QUAL_FLOAT, F32_ZERO, F32_ONE),
    (11, 11, CHANNEL_G | QUAL_FLOAT, F32_ZERO, F32_ONE),
    (22, 10, CHANNEL_B | QUAL_FLOAT, F32_ZERO, F32_ONE)))
R16F = KtxFormat("R16_SFLOAT", 76, 2, 2, (
    (0, 16, CHANNEL_R | QUAL_FLOAT | QUAL_SIGNED, F32_MINUS_ONE, F32_ONE),))
RGBA32F = KtxFormat("R32G32B32A32_SFLOAT", 109, 4, 16, tuple(
    (32 * i, 32, ch | QUAL_FLOAT | QUAL_SIGNED, F32_MINUS_ONE, F32_ONE)
    for i, ch in enumerate((CHANNEL_R, CHANNEL_G, CHANNEL_B, CHANNEL_A))))
RGBA8 = KtxFormat("R8G8B8A8_UNORM", 37, 1, 4, tuple(
    (8 * i, 8, ch, 0, 255) for i, ch in enumerate((CHANNEL_R, CHANNEL_G, CHANNEL_B, CHANNEL_A))))
RGBA8_SRGB = KtxFormat("R8G8B8A8_SRGB", 43, 1, 4, tuple(
    (8 * i, 8, ch | (QUAL_LINEAR if ch == CHANNEL_A else 0), 0, 255)
    for i, ch in enumerate((CHANNEL_R, CHANNEL_G, CHANNEL_B, CHANNEL_A))),
    KHR_DF_TRANSFER_SRGB)
#: every format the reader and writer handle, by vkFormat
KNOWN = {f.vk_format: f for f in (RGBA16F, RGBA32F, B10G11R11, R16F, RGBA8, RGBA8_SRGB)}
FORMATS = {"rgba16f": RGBA16F, "rgba32f": RGBA32F,
           "b10g11r11": B10G11R11}                          # the --format choices (cubemaps)


def dfd_bytes(fmt: KtxFormat) -> bytes:
    """dfdTotalSize then one Basic Data Format Descriptor block (KDF spec §5: 24-byte header,
    16 bytes per sample), little endian."""
    n = len(fmt.samples)
    block = 24 + 16 * n
    words = [0,                                       # vendorId 0 (Khronos), descriptorType 0
             KHR_DF_VERSION | (block << 16),          # versionNumber, descriptorBlockSize
             KHR_DF_MODEL_RGBSDA | (KHR_DF_PRIMARIES_BT709 << 8)
             | (fmt.transfer << 16),                  # flags 0: alpha straight
             0,                                       # texelBlockDimension0..3 = 1×1×1×1
             fmt.texel_bytes,                         # bytesPlane0 (planes 1–3: 0)
             0]                                       # bytesPlane4..7
    for off, length, channel, lower, upper in fmt.samples:
        words += [off | ((length - 1) << 16) | (channel << 24), 0, lower, upper]
    return struct.pack(f"<{1 + len(words)}I", 4 + 4 * len(words), *words)


def kvd_bytes(pairs: dict[str, bytes]) -> bytes:
    """Key/value data: keyAndValueByteLength, key, NUL, value, padding to 4; keys sorted by
    their UTF-8 bytes (spec §3.11)."""
    out = bytearray()
    for key in sorted(pairs, key=lambda k: k.encode("utf-8")):
        kv = key.encode("utf-8") + b"\0" + pairs[key]
        out += struct.pack("<I", len(kv)) + kv
        out += b"\0" * (-len(out) % 4)
    return bytes(out)


def text_value(s: str) -> bytes:
    """A NUL-terminated UTF-8 string value (KTXorientation, KTXwriter, sgpipe's keys)."""
    return s.encode("utf-8") + b"\0"


def _rgba(faces: np.ndarray) -> np.ndarray:
    """RGB (alpha 1) or RGBA, as RGBA."""
    if faces.shape[-1] == 4:
        return faces
    return np.concatenate([faces[..., :3], np.ones(faces.shape[:-1] + (1,))], -1)


def level_bytes(faces: np.ndarray, fmt: KtxFormat) -> bytes:
    """One mip level (6, n, n, C) or (n, n, C) → its faces in order, rows in order, texels
    packed. The RGBA formats take RGB (alpha 1) or RGBA; R16F one channel; B10G11R11 RGB."""
    faces = np.asarray(faces, np.float64)
    if fmt is RGBA16F:
        if faces.shape[-1] == 3:
            return to_half_rgba(faces).astype("<f2").tobytes()
        return np.clip(faces, -65504.0, 65504.0).astype("<f2").tobytes()
    if fmt is RGBA32F:
        return _rgba(faces).astype("<f4").tobytes()
    if fmt in (RGBA8, RGBA8_SRGB):
        v = np.clip(_rgba(faces), 0.0, 1.0)
        if fmt is RGBA8_SRGB:
            v[..., :3] = linear_to_srgb(v[..., :3])
        return np.round(v * 255.0).astype(np.uint8).tobytes()
    if fmt is R16F:
        return np.clip(faces[..., 0], -65504.0, 65504.0).astype("<f2").tobytes()
    return pack_b10g11r11(faces).astype("<u4").tobytes()


def write_ktx2(levels: list[np.ndarray], fmt: KtxFormat, metadata: dict[str, str], *,
               cube: bool = True) -> bytes:
    """A KTX2 file of a mip chain from the base level down: cubemap levels (6, n_m, n_m, C),
    or (cube=False) 2-D levels (n_m, n_m, C); `metadata` extra key/value strings
    (KTXorientation "rd" is always written)."""
    size = levels[0].shape[1] if cube else levels[0].shape[0]
    count = len(levels)
    dfd = dfd_bytes(fmt)
    kvd = kvd_bytes({"KTXorientation": text_value("rd"),
                     **{k: text_value(v) for k, v in metadata.items()}})
    dfd_off = HEADER_BYTES + LEVEL_INDEX_ENTRY * count
    kvd_off = dfd_off + len(dfd)
    data = [level_bytes(lv, fmt) for lv in levels]
    # level data, smallest level first, each start aligned to lcm(texel size, 4)
    pos = kvd_off + len(kvd)
    offsets = [0] * count
    body = bytearray()
    for m in reversed(range(count)):
        pad = -pos % fmt.alignment
        body += b"\0" * pad
        pos += pad
        offsets[m] = pos
        body += data[m]
        pos += len(data[m])
    head = IDENTIFIER + struct.pack(
        "<9I", fmt.vk_format, fmt.type_size, size, size, 0, 0, 6 if cube else 1, count, 0)
    head += struct.pack("<4I2Q", dfd_off, len(dfd), kvd_off, len(kvd), 0, 0)
    index = b"".join(struct.pack("<3Q", offsets[m], len(data[m]), len(data[m]))
                     for m in range(count))
    return head + index + dfd + kvd + bytes(body)


# -- reader -----------------------------------------------------------------------------------
def parse_kvd(buf: bytes) -> list[tuple[str, bytes]]:
    """Key/value pairs in file order (values with their NUL terminators)."""
    out, i = [], 0
    while i < len(buf):
        (length,) = struct.unpack_from("<I", buf, i)
        kv = buf[i + 4:i + 4 + length]
        key, _, value = kv.partition(b"\0")
        out.append((key.decode("utf-8"), value))
        i += 4 + length
        i += -i % 4
    return out


def parse_dfd(buf: bytes) -> dict:
    """dfdTotalSize and the basic block's fields and samples."""
    words = struct.unpack(f"<{len(buf) // 4}I", buf)
    total, w = words[0], words[1:]
    samples = []
    for s in range(((w[1] >> 16) - 24) // 16):
        a, pos, lower, upper = w[6 + 4 * s:10 + 4 * s]
        samples.append({"bit_offset": a & 0xFFFF, "bit_length": ((a >> 16) & 0xFF) + 1,
                        "channel": (a >> 24) & 0x0F, "qualifiers": (a >> 24) & 0xF0,
                        "position": pos, "lower": lower, "upper": upper})
    return {"total_size": total, "vendor_id": w[0] & 0x1FFFF, "descriptor_type": w[0] >> 17,
            "version": w[1] & 0xFFFF, "block_size": w[1] >> 16, "model": w[2] & 0xFF,
            "primaries": (w[2] >> 8) & 0xFF, "transfer": (w[2] >> 16) & 0xFF,
            "flags": w[2] >> 24, "texel_block_dims": w[3], "bytes_plane": [
                (w[4] >> (8 * i)) & 0xFF for i in range(4)] + [
                (w[5] >> (8 * i)) & 0xFF for i in range(4)], "samples": samples}


def read_ktx2(buf: bytes) -> dict:
    """Every field of a KTX2 file written by `write_ktx2` (or another writer, in a format of
    KNOWN, uncompressed), and its levels decoded to float (F, n, n, C) with F the face count
    (the RGBA formats: C = 4, linear; R16F: 1; B10G11R11: 3). Another vkFormat or a
    supercompressed file is a ValueError naming it."""
    if buf[:12] != IDENTIFIER:
        raise ValueError("not a KTX 2.0 file (identifier)")
    keys = ("vk_format", "type_size", "width", "height", "depth", "layers", "faces",
            "level_count", "supercompression")
    hdr = dict(zip(keys, struct.unpack_from("<9I", buf, 12)))
    idx = dict(zip(("dfd_offset", "dfd_length", "kvd_offset", "kvd_length", "sgd_offset",
                    "sgd_length"), struct.unpack_from("<4I2Q", buf, 48)))
    level_index = [dict(zip(("offset", "length", "uncompressed_length"),
                            struct.unpack_from("<3Q", buf, HEADER_BYTES + LEVEL_INDEX_ENTRY * m)))
                   for m in range(hdr["level_count"])]
    fmt = KNOWN.get(hdr["vk_format"])
    if fmt is None:
        raise ValueError(f"KTX2 vkFormat {hdr['vk_format']} is not one sgpipe reads (it reads "
                         + ", ".join(f"{f.name} ({k})" for k, f in sorted(KNOWN.items()))
                         + ")")
    if hdr["supercompression"]:
        raise ValueError(f"KTX2 supercompression scheme {hdr['supercompression']} is not one "
                         "sgpipe reads (it reads uncompressed levels)")
    levels = []
    nf = hdr["faces"]
    for m, e in enumerate(level_index):
        n = max(hdr["width"] >> m, 1)
        raw = buf[e["offset"]:e["offset"] + e["length"]]
        if fmt is B10G11R11:
            levels.append(unpack_b10g11r11(np.frombuffer(raw, "<u4").reshape(nf, n, n)))
        elif fmt is RGBA32F:
            levels.append(np.frombuffer(raw, "<f4").reshape(nf, n, n, 4).astype(np.float64))
        elif fmt in (RGBA8, RGBA8_SRGB):
            v = np.frombuffer(raw, np.uint8).reshape(nf, n, n, 4) / 255.0
            if fmt is RGBA8_SRGB:
                v[..., :3] = srgb_to_linear(v[..., :3])
            levels.append(v)
        else:
            c = 4 if fmt is RGBA16F else 1
            levels.append(np.frombuffer(raw, "<f2").reshape(nf, n, n, c).astype(np.float64))
    return {"header": hdr, "index": idx, "level_index": level_index, "format": fmt,
            "dfd": parse_dfd(buf[idx["dfd_offset"]:idx["dfd_offset"] + idx["dfd_length"]]),
            "kvd": parse_kvd(buf[idx["kvd_offset"]:idx["kvd_offset"] + idx["kvd_length"]]),
            "levels": levels}
