"""glTF 2.0 material textures: images decoded with Pillow (PNG, JPEG; in a `.glb`, a data URI
or a file beside the `.gltf`), their samplers' wrap modes and KHR_texture_transform, and
bilinear lookups at sgpipe UVs.

    tex = material_texture(asset, material_index, "baseColorTexture")   # GltfTexture | None
    rgb = tex.bilinear(uv)          # uv (N, 2) in sgpipe's convention (v = 0 at the bottom)

Base colour (and emissive) images are sRGB-encoded and decoded to linear here; metallic-
roughness and normal images are linear. A texture's lookup follows the specification: the UV is
turned back to glTF's top-left origin, transformed (offset · rotation · scale), wrapped per axis
(REPEAT, CLAMP_TO_EDGE, MIRRORED_REPEAT) and read bilinearly between texel centres.
"""

from __future__ import annotations

import base64
import io
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput
from sgpipe.io.png import srgb_to_linear

REPEAT, CLAMP, MIRROR = 10497, 33071, 33648
SRGB_TEXTURES = ("baseColorTexture", "emissiveTexture")
#: the largest image side read (a 16384² RGBA float image is 4 GiB)
MAX_IMAGE_SIDE = 8192


@dataclass
class GltfTexture:
    """A decoded image (H, W, C) float64, linear, row 0 at the top, and how to sample it."""

    image: np.ndarray
    wrap: tuple[int, int] = (REPEAT, REPEAT)
    matrix: np.ndarray | None = None     # 3×3 KHR_texture_transform, None: identity

    def bilinear(self, uv) -> np.ndarray:
        """(N, C) at sgpipe UVs (N, 2)."""
        uv = np.asarray(uv, float).reshape(-1, 2)
        s, t = uv[:, 0], 1.0 - uv[:, 1]                         # glTF's top-left origin
        if self.matrix is not None:
            m = self.matrix
            s, t = m[0, 0] * s + m[0, 1] * t + m[0, 2], m[1, 0] * s + m[1, 1] * t + m[1, 2]
        h, w = self.image.shape[:2]
        x, y = s * w - 0.5, t * h - 0.5
        x0, y0 = np.floor(x), np.floor(y)
        fx, fy = (x - x0)[:, None], (y - y0)[:, None]
        xs = [_wrap(x0 + k, w, self.wrap[0]) for k in (0, 1)]
        ys = [_wrap(y0 + k, h, self.wrap[1]) for k in (0, 1)]
        img = self.image
        top = img[ys[0], xs[0]] * (1 - fx) + img[ys[0], xs[1]] * fx
        bottom = img[ys[1], xs[0]] * (1 - fx) + img[ys[1], xs[1]] * fx
        return top * (1 - fy) + bottom * fy


def _wrap(i, n, mode) -> np.ndarray:
    i = i.astype(np.int64)
    if mode == CLAMP:
        return np.clip(i, 0, n - 1)
    if mode == MIRROR:
        p = np.mod(i, 2 * n)
        return np.where(p < n, p, 2 * n - 1 - p)
    return np.mod(i, n)


def _decode(data: bytes, path: Path, element: str) -> np.ndarray:
    from PIL import Image, UnidentifiedImageError
    try:
        with Image.open(io.BytesIO(data)) as im:
            if max(im.size) > MAX_IMAGE_SIDE:
                raise BadInput(f"image of {im.size[0]}×{im.size[1]} texels; sgpipe reads at "
                               f"most {MAX_IMAGE_SIDE} per side", file=path, key=element)
            if im.mode in ("I;16", "I;16B", "I;16L", "I"):
                a = np.asarray(im, np.float64) / 65535.0
            else:
                a = np.asarray(im.convert("RGBA" if "A" in im.mode else "RGB"),
                               np.float64) / 255.0
    except BadInput:
        raise
    except (UnidentifiedImageError, OSError, ValueError, SyntaxError) as e:
        raise BadInput(f"cannot decode the image ({type(e).__name__}: "
                       f"{(str(e).splitlines() or [''])[0][:100]})", file=path,
                       key=element) from None
    return np.repeat(a[:, :, None], 3, axis=2) if a.ndim == 2 else a   # grey: R = G = B


def _image_bytes(asset, index: int) -> bytes:
    doc, path = asset.doc, asset.path
    el = f"images[{index}]"
    if not 0 <= index < len(doc.images or []):
        raise BadInput("no such image", file=path, key=el)
    img = doc.images[index]
    if img.bufferView is not None:
        if not 0 <= img.bufferView < len(doc.bufferViews or []):
            raise BadInput("no such buffer view", file=path, key=f"{el}.bufferView")
        bv = doc.bufferViews[img.bufferView]
        blob = asset.blobs[bv.buffer] if 0 <= bv.buffer < len(asset.blobs) else b""
        start = bv.byteOffset or 0
        if start + bv.byteLength > len(blob):
            raise BadInput("its buffer view runs past the end of its buffer", file=path,
                           key=el)
        return blob[start:start + bv.byteLength]
    if not img.uri:
        raise BadInput("neither a uri nor a bufferView", file=path, key=el)
    if img.uri.startswith("data:"):
        head, _, payload = img.uri.partition(",")
        try:
            return base64.b64decode(payload, validate=True)
        except ValueError:
            raise BadInput("data URI is not valid base64", file=path, key=el) from None
    from urllib.parse import unquote
    f = path.parent / unquote(img.uri)
    try:
        return f.read_bytes()
    except OSError as e:
        raise BadInput(f"cannot read {f.name} ({e.strerror or e})", file=path,
                       key=el) from None


def _transform(info) -> np.ndarray | None:
    """KHR_texture_transform's T · R · S as a 3×3 matrix (None without the extension)."""
    ext = (getattr(info, "extensions", None) or {}).get("KHR_texture_transform")
    if not ext:
        return None
    ox, oy = ext.get("offset", (0.0, 0.0))
    r = float(ext.get("rotation", 0.0))
    sx, sy = ext.get("scale", (1.0, 1.0))
    c, s = np.cos(r), np.sin(r)
    t = np.array([[1.0, 0.0, ox], [0.0, 1.0, oy], [0.0, 0.0, 1.0]])
    rot = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    return t @ rot @ np.diag([sx, sy, 1.0])


#: the anisotropy texture's slot name (KHR_materials_anisotropy's textureInfo)
ANISOTROPY_TEXTURE = "KHR_materials_anisotropy.anisotropyTexture"


def _texture_info(m, slot: str):
    """(textureInfo or None, its element path below materials[i]) of a material's slot."""
    if slot == ANISOTROPY_TEXTURE:
        d = ((m.extensions or {}).get("KHR_materials_anisotropy") or {}).get(
            "anisotropyTexture")
        if not d:
            return None, ""
        import pygltflib
        if not isinstance(d, dict):
            return d, f"extensions.{slot}"
        return (pygltflib.TextureInfo(index=d.get("index"), texCoord=d.get("texCoord", 0),
                                      extensions=d.get("extensions") or {}),
                f"extensions.{slot}")
    pbr = slot in ("baseColorTexture", "metallicRoughnessTexture")
    holder = m.pbrMetallicRoughness if pbr else m
    info = getattr(holder, slot, None) if holder is not None else None
    return info, ("pbrMetallicRoughness." if pbr else "") + slot


def material_texture(asset, material: int, slot: str) -> GltfTexture | None:
    """The texture in `slot` (baseColorTexture, metallicRoughnessTexture, normalTexture,
    occlusionTexture, emissiveTexture, ANISOTROPY_TEXTURE) of material `material`, decoded;
    None if it has none."""
    doc, path = asset.doc, asset.path
    info, rel = _texture_info(doc.materials[material], slot)
    if info is None:
        return None
    where = f"materials[{material}].{rel}"
    ext = (getattr(info, "extensions", None) or {}).get("KHR_texture_transform") or {}
    coord = ext.get("texCoord", info.texCoord or 0)
    if coord != 0:
        raise BadInput(f"uses TEXCOORD_{coord}; sgpipe reads TEXCOORD_0 only", file=path,
                       key=where)
    if not 0 <= (info.index if info.index is not None else -1) < len(doc.textures or []):
        raise BadInput("no such texture", file=path, key=f"{where}.index")
    tex = doc.textures[info.index]
    if tex.source is None:
        raise BadInput("texture without an image source", file=path,
                       key=f"textures[{info.index}]")
    image = _decode(_image_bytes(asset, tex.source), path, f"images[{tex.source}]")
    if slot in SRGB_TEXTURES:
        image[..., :3] = srgb_to_linear(image[..., :3])
    wrap = (REPEAT, REPEAT)
    if tex.sampler is not None:
        if not 0 <= tex.sampler < len(doc.samplers or []):
            raise BadInput("no such sampler", file=path, key=f"textures[{info.index}].sampler")
        smp = doc.samplers[tex.sampler]
        wrap = (smp.wrapS or REPEAT, smp.wrapT or REPEAT)
        for axis, mode in zip("ST", wrap):
            if mode not in (REPEAT, CLAMP, MIRROR):
                raise BadInput(f"unknown wrap mode {mode}", file=path,
                               key=f"samplers[{tex.sampler}].wrap{axis}")
    return GltfTexture(image, wrap, _transform(info))
