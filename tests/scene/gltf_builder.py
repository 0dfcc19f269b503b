"""A small glTF 2.0 writer for the tests, on pygltflib: a parent node (translation, rotation,
scale) with an indexed, normal-carrying, UV-mapped quad and a child node (a column-major matrix)
with a non-indexed triangle without normals; two metal-rough materials."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pygltflib as g

QUAD_P = np.array([[-1, 0, -1], [1, 0, -1], [1, 0, 1], [-1, 0, 1]], np.float32)
QUAD_N = np.array([[0, 1, 0]] * 4, np.float32)
QUAD_UV = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
QUAD_I = np.array([0, 2, 1, 0, 3, 2], np.uint16)          # counter-clockwise seen from +Y
TRI_P = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32)
PARENT_T = (0.5, 1.0, -2.0)
PARENT_R = (0.0, np.sin(np.pi / 8), 0.0, np.cos(np.pi / 8))   # 45° about +Y (x, y, z, w)
PARENT_S = (2.0, 2.0, 2.0)
CHILD_M = np.array([[1, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [3, 0, 0, 1]], float)  # +3 x
MATERIALS = [
    {"name": "red plastic", "base": [0.8, 0.1, 0.05, 1.0], "metallic": 0.0, "roughness": 0.4},
    {"name": "gold", "base": [1.0, 0.78, 0.34, 1.0], "metallic": 1.0, "roughness": 0.2},
]


def build(mode: int = 4, extensions_required=(), metallic0: float = 0.0) -> g.GLTF2:
    blob = b""
    views, accessors = [], []

    def add(arr, target, comp, typ, minmax=False):
        nonlocal blob
        blob += b"\0" * (-len(blob) % 4)
        data = np.ascontiguousarray(arr).tobytes()
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data),
                                  target=target))
        blob += data
        acc = g.Accessor(bufferView=len(views) - 1, componentType=comp, count=len(arr),
                         type=typ)
        if minmax:
            acc.min, acc.max = arr.min(0).tolist(), arr.max(0).tolist()
        accessors.append(acc)
        return len(accessors) - 1

    qp = add(QUAD_P, g.ARRAY_BUFFER, g.FLOAT, g.VEC3, True)
    qn = add(QUAD_N, g.ARRAY_BUFFER, g.FLOAT, g.VEC3)
    quv = add(QUAD_UV, g.ARRAY_BUFFER, g.FLOAT, g.VEC2)
    qi = add(QUAD_I, g.ELEMENT_ARRAY_BUFFER, g.UNSIGNED_SHORT, g.SCALAR)
    tp = add(TRI_P, g.ARRAY_BUFFER, g.FLOAT, g.VEC3, True)
    mats = []
    for k, m in enumerate(MATERIALS):
        mats.append(g.Material(name=m["name"], pbrMetallicRoughness=g.PbrMetallicRoughness(
            baseColorFactor=m["base"], metallicFactor=metallic0 if k == 0 else m["metallic"],
            roughnessFactor=m["roughness"])))
    doc = g.GLTF2(
        asset=g.Asset(version="2.0", generator="sgpipe tests (pygltflib)"),
        scene=0, scenes=[g.Scene(nodes=[0])],
        nodes=[g.Node(name="base", mesh=0, children=[1], translation=list(PARENT_T),
                      rotation=list(PARENT_R), scale=list(PARENT_S)),
               g.Node(name="fin", mesh=1, matrix=CHILD_M.ravel().tolist())],
        meshes=[g.Mesh(name="quad", primitives=[g.Primitive(
                    attributes=g.Attributes(POSITION=qp, NORMAL=qn, TEXCOORD_0=quv),
                    indices=qi, material=0, mode=mode)]),
                g.Mesh(name="tri", primitives=[g.Primitive(
                    attributes=g.Attributes(POSITION=tp), material=1)])],
        materials=mats, accessors=accessors, bufferViews=views,
        buffers=[g.Buffer(byteLength=len(blob))],
        extensionsRequired=list(extensions_required),
        extensionsUsed=list(extensions_required))
    doc.set_binary_blob(blob)
    return doc


def write_glb(doc: g.GLTF2, path: Path) -> Path:
    doc.save_binary(str(path))
    return path


def write_gltf(doc: g.GLTF2, path: Path) -> Path:
    """.gltf with its buffer in `<stem>.bin` beside it."""
    blob = doc.binary_blob()
    bin_path = path.with_suffix(".bin")
    bin_path.write_bytes(blob)
    doc = g.GLTF2.from_json(doc.to_json())
    doc.buffers[0].uri = bin_path.name
    doc.save_json(str(path))
    return path


def write_gltf_embedded(doc: g.GLTF2, path: Path) -> Path:
    """.gltf with its buffer inside, as a base64 data URI."""
    import base64
    blob = doc.binary_blob()
    doc = g.GLTF2.from_json(doc.to_json())
    doc.buffers[0].uri = ("data:application/octet-stream;base64,"
                          + base64.b64encode(blob).decode("ascii"))
    doc.save_json(str(path))
    return path


def parent_matrix() -> np.ndarray:
    x, y, z, w = PARENT_R
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    m = np.eye(4)
    m[:3, :3] = r * np.asarray(PARENT_S)
    m[:3, 3] = PARENT_T
    return m


def glb_header(path: Path) -> tuple[int, int, int]:
    return struct.unpack_from("<III", path.read_bytes(), 0)


def png_bytes(img: np.ndarray) -> bytes:
    """8-bit PNG of an (H, W, 3) image in [0, 1] (row 0 at the top)."""
    import io

    from PIL import Image
    buf = io.BytesIO()
    Image.fromarray(np.round(np.clip(img, 0, 1) * 255).astype(np.uint8)).save(buf, "PNG")
    return buf.getvalue()


def textured_quad(base_img=None, mr_img=None, *, base=(1.0, 1.0, 1.0), metallic=1.0,
                  roughness=1.0, wrap=33071, normal_img=None) -> g.GLTF2:
    """A 2 × 2 quad in the x-y plane facing +z, UVs (0, 0) at its top-left corner (glTF's
    origin) to (1, 1), one material with optional base-colour, metallic-roughness and normal
    PNGs (no TANGENT: MikkTSpace's tangent runs along +x)."""
    p = np.array([[-1, 1, 0], [1, 1, 0], [1, -1, 0], [-1, -1, 0]], np.float32)
    n = np.array([[0, 0, 1]] * 4, np.float32)
    uv = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    idx = np.array([0, 3, 2, 0, 2, 1], np.uint16)
    return primitive_doc(p, n, uv, idx, {"baseColorTexture": base_img,
                                         "metallicRoughnessTexture": mr_img,
                                         "normalTexture": normal_img},
                         base=base, metallic=metallic, roughness=roughness, wrap=wrap)


def primitive_doc(p, n, uv, idx, images: dict, *, tangents=None, normal_scale=None,
                  base=(1.0, 1.0, 1.0), metallic=1.0, roughness=1.0, wrap=33071,
                  emissive=None, emissive_strength=None) -> g.GLTF2:
    """One indexed primitive (positions, normals, glTF UVs, optional TANGENT) with one
    material whose textures are PNGs: `images` {slot: (H, W, 3) image or None} for
    baseColorTexture, metallicRoughnessTexture, normalTexture (with `normal_scale`) and
    emissiveTexture; `emissive`: emissiveFactor, `emissive_strength`: the material's
    KHR_materials_emissive_strength."""
    blob, views, accessors = b"", [], []

    def view(data: bytes, target=None) -> int:
        nonlocal blob
        blob += b"\0" * (-len(blob) % 4)
        views.append(g.BufferView(buffer=0, byteOffset=len(blob), byteLength=len(data),
                                  target=target))
        blob += data
        return len(views) - 1

    def acc(arr, comp, typ, target):
        accessors.append(g.Accessor(bufferView=view(np.ascontiguousarray(arr).tobytes(), target),
                                    componentType=comp, count=len(arr), type=typ))
        if typ == g.VEC3 and comp == g.FLOAT:
            accessors[-1].min, accessors[-1].max = arr.min(0).tolist(), arr.max(0).tolist()
        return len(accessors) - 1

    f32 = lambda a: np.asarray(a, np.float32)  # noqa: E731
    attrs = g.Attributes(POSITION=acc(f32(p), g.FLOAT, g.VEC3, g.ARRAY_BUFFER),
                         NORMAL=acc(f32(n), g.FLOAT, g.VEC3, g.ARRAY_BUFFER),
                         TEXCOORD_0=acc(f32(uv), g.FLOAT, g.VEC2, g.ARRAY_BUFFER))
    if tangents is not None:
        attrs.TANGENT = acc(f32(tangents), g.FLOAT, g.VEC4, g.ARRAY_BUFFER)
    ind = acc(np.asarray(idx, np.uint16), g.UNSIGNED_SHORT, g.SCALAR, g.ELEMENT_ARRAY_BUFFER)
    images_, textures = [], []
    pbr = g.PbrMetallicRoughness(baseColorFactor=[*base, 1.0], metallicFactor=metallic,
                                 roughnessFactor=roughness)
    material = g.Material(name="painted", pbrMetallicRoughness=pbr,
                          emissiveFactor=[0.0, 0.0, 0.0] if emissive is None else list(emissive))
    used = []
    if emissive_strength is not None:
        material.extensions = {"KHR_materials_emissive_strength":
                               {"emissiveStrength": emissive_strength}}
        used.append("KHR_materials_emissive_strength")
    for slot, img in images.items():
        if img is None:
            continue
        images_.append(g.Image(bufferView=view(png_bytes(img)), mimeType="image/png"))
        textures.append(g.Texture(source=len(images_) - 1, sampler=0))
        if slot == "normalTexture":
            material.normalTexture = g.NormalMaterialTexture(index=len(textures) - 1,
                                                             scale=normal_scale)
        elif slot == "emissiveTexture":
            material.emissiveTexture = g.TextureInfo(index=len(textures) - 1)
        else:
            setattr(pbr, slot, g.TextureInfo(index=len(textures) - 1))
    doc = g.GLTF2(asset=g.Asset(version="2.0"), scene=0, scenes=[g.Scene(nodes=[0])],
                  nodes=[g.Node(name="quad", mesh=0)],
                  meshes=[g.Mesh(primitives=[g.Primitive(attributes=attrs, indices=ind,
                                                         material=0)])],
                  materials=[material], images=images_, textures=textures,
                  samplers=[g.Sampler(wrapS=wrap, wrapT=wrap)],
                  accessors=accessors, bufferViews=views,
                  buffers=[g.Buffer(byteLength=len(blob))], extensionsUsed=used,
                  extensionsRequired=[])
    doc.set_binary_blob(blob)
    return doc


def mirrored_strip(images=None, *, normals=None, tangents=None, normal_scale=None,
                   roughness=0.4) -> g.GLTF2:
    """A 2 × 2 square facing +z in two halves whose UVs mirror each other at x = 0 (u = |x|,
    glTF v = 0 at the top edge y = 1), the seam's vertices doubled; a grey dielectric.
    `normals` (2, 3): per half (left, right) a NORMAL for its four vertices (default +z);
    `tangents` (2, 4): per half a TANGENT."""
    x = np.array([[-1, 0, 0, -1], [0, 1, 1, 0]], float)
    y = np.array([[1, 1, -1, -1], [1, 1, -1, -1]], float)
    p = np.stack([x, y, np.zeros_like(x)], -1).reshape(-1, 3)
    uv = np.stack([np.abs(x), (1.0 - y) / 2], -1).reshape(-1, 2)
    nn = np.tile([0.0, 0.0, 1.0], (2, 1)) if normals is None else np.asarray(normals, float)
    n = np.repeat(nn, 4, axis=0)
    t = None if tangents is None else np.repeat(np.asarray(tangents, float), 4, axis=0)
    # counter-clockwise seen from +z: left (0, 3, 2), (0, 2, 1); right (4, 7, 6), (4, 6, 5)
    idx = np.array([0, 3, 2, 0, 2, 1, 4, 7, 6, 4, 6, 5])
    return primitive_doc(p, n, uv, idx, images or {}, tangents=t, normal_scale=normal_scale,
                         base=(0.5, 0.5, 0.5), metallic=0.0, roughness=roughness)


#: a normal texture's normal: 30° off +Z towards 60° from +X (so it leans along +Y too)
TILT = np.array([np.sin(np.pi / 6) * np.cos(np.pi / 3), np.sin(np.pi / 6) * np.sin(np.pi / 3),
                 np.cos(np.pi / 6)])


def tilted_strips(folder: Path, given: str) -> tuple[Path, Path, Path]:
    """The mirrored strip with a constant 4 × 4 normal texture of TILT (8-bit) — `given`
    "mikktspace": no TANGENT, the texture's scale 0.7; "tangent": TANGENTs −x (w −1) / +x
    (w 1), scale 1 — the same strip with the normal the texels decode to as geometry (x
    mirrored on the left half, (s x, s y, z) under the scale s), and that strip with the left
    half's y flipped too (+Y along n × t, w ignored): (textured, baked, flipped) .glb files."""
    c = np.round((TILT + 1.0) / 2.0 * 255.0) / 255.0
    img, n = np.tile(c, (4, 4, 1)), 2.0 * c - 1.0
    scale = 0.7 if given == "mikktspace" else None
    tangents = None if given == "mikktspace" else [[-1, 0, 0, -1], [1, 0, 0, 1]]
    textured = write_glb(mirrored_strip({"normalTexture": img}, tangents=tangents,
                                        normal_scale=scale), folder / "tex.glb")
    s = 1.0 if scale is None else scale
    right = np.array([s * n[0], s * n[1], n[2]])
    right /= np.linalg.norm(right)
    left = right * [-1.0, 1.0, 1.0]
    baked = write_glb(mirrored_strip(normals=[left, right]), folder / "baked.glb")
    flipped = write_glb(mirrored_strip(normals=[left * [1.0, -1.0, 1.0], right]),
                        folder / "flipped.glb")
    return textured, baked, flipped


#: the two-material quad's halves: base colours (sRGB) and (roughness, metallic)
HALF_A, HALF_B = np.array([0.8, 0.3, 0.1]), np.array([0.1, 0.4, 0.9])
HALF_MATERIALS = {"a": (HALF_A, 0.3, 0.0), "b": (HALF_B, 0.7, 1.0)}


def halves(a, b, size=32) -> np.ndarray:
    """A size² image whose left half is a and right half b (the seam at column size / 2)."""
    img = np.empty((size, size, 3))
    img[:, : size // 2] = a
    img[:, size // 2:] = b
    return img


def halves_quads(folder: Path) -> tuple[Path, dict[str, Path]]:
    """The textured quad whose halves are two materials (left: base HALF_A, roughness 0.3,
    dielectric; right: HALF_B, roughness 0.7, metal) and, per half, the uniform quad of that
    material at its texels' 8-bit values: (textured .glb, {"a": .glb, "b": .glb})."""
    from sgpipe.io.png import srgb_to_linear
    mr = halves([0, 0.3, 0.0], [0, 0.7, 1.0])
    tex = write_glb(textured_quad(halves(HALF_A, HALF_B), mr), folder / "tex.glb")
    uniform = {}
    for tag, (c, r, m) in HALF_MATERIALS.items():
        lin = srgb_to_linear(np.round(c * 255) / 255)          # the PNG's 8 bits
        uniform[tag] = write_glb(textured_quad(base=tuple(lin), metallic=m,
                                               roughness=np.round(r * 255) / 255),
                                 folder / f"{tag}.glb")
    return tex, uniform


def add_anisotropy(doc: g.GLTF2, strength: float, rotation: float = 0.0,
                   image: np.ndarray | None = None) -> g.GLTF2:
    """KHR_materials_anisotropy on the document's first material, with `image` (a PNG of
    (H, W, 3) in [0, 1]: RG direction, B strength) as its anisotropyTexture when given."""
    ext = {"anisotropyStrength": strength, "anisotropyRotation": rotation}
    if image is not None:
        blob = bytearray(doc.binary_blob())
        blob.extend(b"\0" * (-len(blob) % 4))
        data = png_bytes(image)
        doc.bufferViews.append(g.BufferView(buffer=0, byteOffset=len(blob),
                                            byteLength=len(data)))
        blob.extend(data)
        doc.images.append(g.Image(bufferView=len(doc.bufferViews) - 1, mimeType="image/png"))
        doc.textures.append(g.Texture(source=len(doc.images) - 1, sampler=0))
        ext["anisotropyTexture"] = {"index": len(doc.textures) - 1}
        doc.buffers[0].byteLength = len(blob)
        doc.set_binary_blob(bytes(blob))
    doc.materials[0].extensions = {**(doc.materials[0].extensions or {}),
                                   "KHR_materials_anisotropy": ext}
    doc.extensionsUsed = sorted(set(doc.extensionsUsed or []) | {"KHR_materials_anisotropy"})
    return doc


STUDIO = Path(__file__).resolve().parents[2] / "data_samples" / "studio.exr"


def render_quad(folder: Path, glb: Path, tag: str, methods, *, light: bool = False,
                fit: str = "{view_gmm: {enabled: false}}", sections: str = "",
                render: str = "") -> dict:
    """`sgpipe run` of a glTF file seen from +z at 3 units (32², the studio map at cube 32):
    under one point light (the map dimmed by 2⁻³⁰) or the map at exposure −2; `fit` the fit
    section, `sections` further top-level YAML lines, `render` further render lines (each
    ending in a newline) -> {method: image (32, 32, 3)}."""
    import subprocess
    import sys

    from sgpipe.io import read_exr
    cfg = folder / f"{tag}.yaml"
    lights = ("lights: [{type: point, position: [0.6, 0.4, 1.5], intensity: [5, 5, 5], "
              "radius: 0.0}]\n  environment_exposure: -30" if light else
              "environment_exposure: -2")
    cfg.write_text(f"""
scene: {{gltf: [{{file: {glb}}}]}}
fit: {fit}
{sections}envmap: {{environment: {STUDIO}, cube_resolution: 32}}
render:
  camera: {{eye: [0, 0, 3.0], target: [0, 0, 0], fov_deg: 30, width: 32, height: 32}}
  methods: [{', '.join(methods)}]
{render}  {lights}
""")
    out = folder / f"out_{tag}"
    r = subprocess.run([sys.executable, "-m", "sgpipe", "run", str(cfg), "--out", str(out)],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr[-2000:]
    return {m: read_exr(out / "render" / f"{m}.exr")[..., :3] for m in methods}
