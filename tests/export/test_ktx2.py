"""KTX 2.0 container: every byte field of the header, index, level index, DFD and key/value
data checked against the specification's values; pixels round-trip; B10G11R11 packing against
numpy's float16 and a nearest-value search over every code."""

import struct

import numpy as np
import pytest

from sgpipe.export import ktx2
from sgpipe.export.packed_float import decode_ufloat, encode_ufloat, max_finite, unpack_b10g11r11

META = {"KTXwriter": "sgpipe test",
        "sgpipe.roughnessMapping": "roughness = level / (levelCount - 1)"}


def chain(size=8, seed=0):
    rng = np.random.default_rng(seed)
    out, n = [], size
    while n >= 1:
        out.append(rng.lognormal(0.0, 2.0, size=(6, n, n, 3)))
        n //= 2
    return out


def test_rgba16f_every_field():
    levels = chain(8)
    buf = ktx2.write_ktx2(levels, ktx2.RGBA16F, META)
    assert buf[:12] == bytes([0xAB, 0x4B, 0x54, 0x58, 0x20, 0x32, 0x30, 0xBB, 0x0D, 0x0A, 0x1A,
                              0x0A])                                    # «KTX 20»\r\n\x1A\n
    hdr = struct.unpack_from("<9I", buf, 12)
    # vkFormat 97 = R16G16B16A16_SFLOAT, typeSize 2, 8×8, depth 0, layers 0, 6 faces, 4 levels,
    # no supercompression
    assert hdr == (97, 2, 8, 8, 0, 0, 6, 4, 0)
    dfd_off, dfd_len, kvd_off, kvd_len, sgd_off, sgd_len = struct.unpack_from("<4I2Q", buf, 48)
    assert dfd_off == 80 + 24 * 4 and dfd_len == 4 + 24 + 16 * 4
    assert kvd_off == dfd_off + dfd_len and (sgd_off, sgd_len) == (0, 0)
    # DFD: total size, then the basic block word by word
    words = struct.unpack_from(f"<{dfd_len // 4}I", buf, dfd_off)
    assert words[:7] == (92, 0, 2 | (88 << 16), 1 | (1 << 8) | (1 << 16), 0, 8, 0)
    for i, ch in enumerate((0, 1, 2, 15)):                  # R, G, B, A; FLOAT | SIGNED
        assert words[7 + 4 * i:11 + 4 * i] == (16 * i | (15 << 16) | ((ch | 0xC0) << 24), 0,
                                                0xBF800000, 0x3F800000)
    # key/value data: sorted keys, length-prefixed, NUL-terminated values, 4-byte padding
    kv = buf[kvd_off:kvd_off + kvd_len]
    pos, keys = 0, []
    while pos < len(kv):
        (n,) = struct.unpack_from("<I", kv, pos)
        key, value = kv[pos + 4:pos + 4 + n].split(b"\0", 1)
        keys.append(key)
        assert value.endswith(b"\0")
        if key == b"KTXorientation":
            assert value == b"rd\0"
        pos += 4 + n
        assert kv[pos:pos + (-pos % 4)] == b"\0" * (-pos % 4)
        pos += -pos % 4
    assert keys == sorted(keys) == [b"KTXorientation", b"KTXwriter", b"sgpipe.roughnessMapping"]
    # level index: offsets 8-aligned (lcm(8, 4)), smallest level first in the file, tight
    idx = [struct.unpack_from("<3Q", buf, 80 + 24 * m) for m in range(4)]
    sizes = [6 * n * n * 8 for n in (8, 4, 2, 1)]
    assert [(l, u) for _, l, u in idx] == [(s, s) for s in sizes]
    offs = [o for o, _, _ in idx]
    assert all(o % 8 == 0 for o in offs) and offs == sorted(offs, reverse=True)
    first = kvd_off + kvd_len
    assert offs[3] == first + (-first % 8) and buf[first:offs[3]] == b"\0" * (offs[3] - first)
    for m in (3, 2, 1):
        assert offs[m - 1] == offs[m] + sizes[m]              # no padding needed between
    assert len(buf) == offs[0] + sizes[0]
    # pixels: faces in order, rows in order, RGBA half, alpha 1
    for m, lv in enumerate(levels):
        px = np.frombuffer(buf, "<f2", 6 * lv.shape[1] ** 2 * 4, offs[m]).reshape(*lv.shape[:3], 4)
        assert np.array_equal(px[..., :3], lv.astype(np.float16))
        assert np.all(px[..., 3] == 1.0)


def test_reader_parses_what_the_writer_wrote():
    levels = chain(4, seed=2)
    r = ktx2.read_ktx2(ktx2.write_ktx2(levels, ktx2.RGBA16F, META))
    assert r["header"]["level_count"] == 3 and r["dfd"]["samples"][3]["channel"] == 15
    assert dict(r["kvd"])["KTXorientation"] == b"rd\0"
    for got, want in zip(r["levels"], levels):
        np.testing.assert_array_equal(got[..., :3], want.astype(np.float16).astype(float))


def test_b10g11r11_fields_and_pixels():
    levels = chain(4, seed=1)
    buf = ktx2.write_ktx2(levels, ktx2.B10G11R11, META)
    assert struct.unpack_from("<9I", buf, 12) == (122, 4, 4, 4, 0, 0, 6, 3, 0)
    r = ktx2.read_ktx2(buf)
    d = r["dfd"]
    assert (d["total_size"], d["block_size"]) == (76, 72)
    assert d["bytes_plane"] == [4, 0, 0, 0, 0, 0, 0, 0]
    assert [(s["bit_offset"], s["bit_length"], s["channel"], s["qualifiers"], s["lower"],
             s["upper"]) for s in d["samples"]] == [
        (0, 11, 0, 0x80, 0, 0x3F800000), (11, 11, 1, 0x80, 0, 0x3F800000),
        (22, 10, 2, 0x80, 0, 0x3F800000)]
    offs = [e["offset"] for e in r["level_index"]]
    assert all(o % 4 == 0 for o in offs) and offs == sorted(offs, reverse=True)
    for m, lv in enumerate(levels):
        raw = np.frombuffer(buf, "<u4", 6 * lv.shape[1] ** 2, offs[m])
        np.testing.assert_array_equal(unpack_b10g11r11(raw).reshape(lv.shape), r["levels"][m])
        np.testing.assert_allclose(r["levels"][m], lv, rtol=2.0 ** -6)   # ≤ half a step


def test_packed_floats_against_numpy_float16():
    """Values exactly representable in 11 / 10 bits are float16 values with the low mantissa
    bits zero: their codes are float16's bits shifted (the formats share exponent and bias)."""
    h = np.arange(0, 0x7C00, dtype=np.uint16)                # every finite positive float16
    x = h.view(np.float16).astype(np.float64)
    for mb, shift in ((6, 4), (5, 5)):
        exact = (h & ((1 << shift) - 1)) == 0
        np.testing.assert_array_equal(encode_ufloat(x[exact], mb), h[exact] >> shift)
        np.testing.assert_array_equal(decode_ufloat(h[exact] >> shift, mb), x[exact])


@pytest.mark.parametrize("mb", [6, 5])
def test_packed_floats_round_to_the_nearest_code(mb):
    codes = np.arange(31 << mb)                              # every finite code
    values = decode_ufloat(codes, mb)
    assert np.all(np.diff(values) > 0) and values[-1] == max_finite(mb)
    rng = np.random.default_rng(4)
    x = np.concatenate([rng.lognormal(0, 8, 100000), (values[1:] + values[:-1]) / 2,
                        [0.0, 1e-30, 1e9, -5.0, np.nan]])
    got = decode_ufloat(encode_ufloat(x, mb), mb)
    xc = np.clip(np.nan_to_num(x, nan=0.0), 0.0, values[-1])
    i = np.clip(np.searchsorted(values, xc), 1, len(values) - 1)
    nearest = np.minimum(np.abs(values[i] - xc), np.abs(values[i - 1] - xc))
    assert np.all(np.abs(got - xc) <= nearest)
    # ties go to the even code
    mids = (values[1:] + values[:-1]) / 2
    tie_codes = encode_ufloat(mids, mb)
    assert np.all(tie_codes % 2 == 0)


def test_rgba32f_fields_and_pixels():
    """vkFormat 109, typeSize 4, 16-byte texels (levels 16-aligned), DFD samples 32 bits each,
    FLOAT | SIGNED with bounds −1 / 1; pixels exact in float32, alpha 1."""
    levels = chain(4, seed=3)
    buf = ktx2.write_ktx2(levels, ktx2.RGBA32F, META)
    assert struct.unpack_from("<9I", buf, 12) == (109, 4, 4, 4, 0, 0, 6, 3, 0)
    r = ktx2.read_ktx2(buf)
    assert [(s["bit_offset"], s["bit_length"], s["channel"], s["qualifiers"], s["lower"],
             s["upper"]) for s in r["dfd"]["samples"]] == [
        (32 * i, 32, ch, 0xC0, 0xBF800000, 0x3F800000) for i, ch in enumerate((0, 1, 2, 15))]
    assert r["dfd"]["bytes_plane"][0] == 16 and r["dfd"]["transfer"] == 1
    assert all(e["offset"] % 16 == 0 for e in r["level_index"])
    for got, want in zip(r["levels"], levels):
        np.testing.assert_array_equal(got[..., :3], want.astype(np.float32))
        assert np.all(got[..., 3] == 1.0)


@pytest.mark.parametrize("fmt,vk,transfer", [(ktx2.RGBA8, 37, 1), (ktx2.RGBA8_SRGB, 43, 2)])
def test_rgba8_unorm_and_srgb(fmt, vk, transfer):
    """8-bit: values clamped to [0, 1]; the sRGB format's DFD says transfer 2 (sRGB) with alpha
    marked linear (KDF: KHR_DF_SAMPLE_DATATYPE_LINEAR), and its RGB round-trips through the
    curve within half a code step."""
    rng = np.random.default_rng(5)
    levels = [rng.random((6, n, n, 3)) for n in (4, 2, 1)]
    r = ktx2.read_ktx2(ktx2.write_ktx2(levels, fmt, META))
    assert r["header"]["vk_format"] == vk and r["header"]["type_size"] == 1
    assert r["dfd"]["transfer"] == transfer
    quals = [s["qualifiers"] for s in r["dfd"]["samples"]]
    assert quals == ([0, 0, 0, 0x10] if transfer == 2 else [0, 0, 0, 0])
    for got, want in zip(r["levels"], levels):
        if transfer == 1:
            np.testing.assert_allclose(got[..., :3], want, atol=0.5 / 255 + 1e-12)
        else:     # half a code in the encoded domain, times the curve's steepest slope there
            enc = np.where(want <= 0.0031308, 12.92 * want, 1.055 * want ** (1 / 2.4) - 0.055)
            top = np.minimum(enc + 0.5 / 255, 1.0)
            slope = np.maximum(2.4 / 1.055 * ((top + 0.055) / 1.055) ** 1.4, 1 / 12.92)
            assert np.all(np.abs(got[..., :3] - want) <= 0.5 / 255 * slope + 1e-9)
        assert np.all(got[..., 3] == 1.0)


def test_unknown_format_and_supercompression_are_named():
    buf = bytearray(ktx2.write_ktx2(chain(2), ktx2.RGBA16F, META))
    struct.pack_into("<I", buf, 12, 131)                       # BC1_RGB_UNORM_BLOCK
    with pytest.raises(ValueError, match="vkFormat 131 is not one sgpipe reads"):
        ktx2.read_ktx2(bytes(buf))
    buf = bytearray(ktx2.write_ktx2(chain(2), ktx2.RGBA16F, META))
    struct.pack_into("<I", buf, 12 + 32, 2)                    # Zstandard
    with pytest.raises(ValueError, match="supercompression scheme 2"):
        ktx2.read_ktx2(bytes(buf))
