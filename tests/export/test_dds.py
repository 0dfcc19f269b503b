"""DDS cubemaps: header fields, our reader, and OpenImageIO reading the same container.

OpenImageIO 3.2 reads no float DXGI format ("Unsupported DXGI format: 10"), so it checks the
container (header, cube faces, mip order and offsets) on the same writer's R8G8B8A8_UNORM
output; the float file differs from it only in dxgiFormat, pitch and texel bytes."""

import struct

import numpy as np

from sgpipe.export import dds


def chain(size=8, seed=0, hi=20.0):
    rng = np.random.default_rng(seed)
    return [rng.uniform(0, hi, size=(6, n, n, 3)) for n in (size >> m for m in range(
        int(np.log2(size)) + 1))]


def test_header_fields_and_reader():
    levels = chain(8)
    buf = dds.write_dds(levels)
    assert buf[:4] == b"DDS "
    size, flags, h, w, pitch, depth, mips = struct.unpack_from("<7I", buf, 4)
    assert (size, h, w, pitch, depth, mips) == (124, 8, 8, 64, 0, 4)
    assert flags == 0x1 | 0x2 | 0x4 | 0x8 | 0x1000 | 0x20000
    pf_size, pf_flags, fourcc = struct.unpack_from("<II4s", buf, 76)
    assert (pf_size, pf_flags, fourcc) == (32, 0x4, b"DX10")
    caps = struct.unpack_from("<4I", buf, 108)
    assert caps == (0x8 | 0x1000 | 0x400000, 0x200 | 0xFC00, 0, 0)
    assert struct.unpack_from("<5I", buf, 128) == (10, 3, 0x4, 1, 1)
    assert len(buf) == 148 + 6 * sum(8 * n * n for n in (8, 4, 2, 1))
    r = dds.read_dds(buf)
    assert r["end"] == len(buf)
    for got, want in zip(r["levels"], levels):
        np.testing.assert_array_equal(got[..., :3], want.astype(np.float16).astype(float))
        assert np.all(got[..., 3] == 1.0)


def _oiio_faces(path, n_levels):
    """Every face of every mip through OpenImageIO's tile reader. OIIO 3.2's DDS reader
    halves a cube's size one time too few for mips ≥ 1 (seek_subimage loops from 1), so it
    reads a tile larger than the face from the right offset: the first n² texels are the
    face; the file copy gets `pad` zero bytes so the last face's oversized read stays inside."""
    import OpenImageIO as oiio
    inp = oiio.ImageInput.open(str(path))
    assert inp is not None, oiio.geterror()
    spec = inp.spec()
    assert spec.get_string_attribute("textureformat") == "CubeFace Environment"
    assert spec.get_string_attribute("dds:CubeMapSides") == "+x -x +y -y +z -z"
    assert spec.get_int_attribute("oiio:miplevels") == n_levels
    out = []
    for m in range(n_levels):
        assert inp.seek_subimage(0, m)
        th = inp.spec().tile_height
        n = max(spec.width >> m, 1)
        faces = []
        for f in range(6):
            t = inp.read_tile(0, f * th, 0, "uint8")
            assert t is not None, inp.geterror()
            faces.append(np.asarray(t).reshape(-1, 4)[:n * n].reshape(n, n, 4))
        out.append(np.stack(faces))
    inp.close()
    return out


def test_openimageio_reads_the_container(tmp_path):
    levels = chain(8, seed=3, hi=1.0)
    buf = dds.write_dds(levels, dds.DXGI_FORMAT_R8G8B8A8_UNORM)
    path = tmp_path / "cube8.dds"
    path.write_bytes(buf + b"\0" * 4096)
    got = _oiio_faces(path, 4)
    for g, lv in zip(got, levels):
        np.testing.assert_array_equal(g[..., :3], np.rint(255 * lv))
        assert np.all(g[..., 3] == 255)
    # the float file: the same header but dxgiFormat and pitch, the same face/mip order
    fbuf = dds.write_dds(levels)
    diff = [i for i in range(148) if fbuf[i] != buf[i]]
    assert set(diff) <= set(range(20, 24)) | set(range(128, 132))
    assert len(fbuf) - 148 == 2 * (len(buf) - 148)         # 8 bytes a texel instead of 4


def test_openimageio_on_the_float_file(tmp_path):
    """Today OIIO refuses DXGI 10 with one message; if a later OIIO reads it, its texels must
    be ours."""
    import OpenImageIO as oiio
    levels = chain(4, seed=5)
    path = tmp_path / "cube.dds"
    path.write_bytes(dds.write_dds(levels))
    inp = oiio.ImageInput.open(str(path))
    if inp is None:
        assert "DXGI format: 10" in oiio.geterror()
        return
    px = inp.read_image(0, 0, 0, 4, "float")
    inp.close()
    np.testing.assert_array_equal(px[..., :3].reshape(6, 4, 4, 3),
                                  levels[0].astype(np.float16).astype(np.float32))
