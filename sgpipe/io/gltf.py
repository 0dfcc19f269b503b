"""glTF 2.0 scenes (`.gltf` + buffers, `.glb`) read with pygltflib: the node hierarchy's
triangle primitives in world space (with MikkTSpace tangents where a material needs a tangent
frame the file does not give: sgpipe.io.mikktspace) and the materials (sgpipe.io.gltf_materials).

    asset = read_gltf("helmet.glb")                  # structure, validated; no geometry yet
    asset.primitives                                 # [PrimitiveRef(node, mesh, primitive, ...)]
    geo = primitive_geometry(asset, asset.primitives[0])   # positions / normals / uvs /
                                                           # tangents / faces

Conventions (docs/CONVENTIONS.md): glTF is right-handed with +Y up, as sgpipe's world; its UV
origin is the image's top-left, so `v` becomes 1 − v (sgpipe follows OBJ: v = 0 is the bottom
row). Primitives without NORMAL are flat-shaded (the specification's rule): each triangle gets
its own three vertices and its face normal.

Every defect is one BadInput naming the file and the glTF element (`meshes[0].primitives[1]
.mode`, `accessors[3]`, `buffers[0]`): a bad GLB header or chunk length, a truncated buffer, an
accessor past its buffer view, a non-triangle primitive, an `extensionsRequired` entry sgpipe
does not implement, out-of-range material factors.
"""

from __future__ import annotations

import base64
import re
import struct
import warnings
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput
from sgpipe.io.gltf_materials import GltfMaterial, read_materials  # noqa: F401
from sgpipe.io.gltf_materials import fail as _fail

#: extensions whose content sgpipe reads; a file that *requires* any other is refused
SUPPORTED_EXTENSIONS = ("KHR_materials_anisotropy", "KHR_materials_emissive_strength")

_COMPONENT = {5120: np.int8, 5121: np.uint8, 5122: np.int16, 5123: np.uint16, 5125: np.uint32,
              5126: np.float32}
_WIDTH = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
_GLB_MAGIC, _JSON_CHUNK, _BIN_CHUNK = 0x46546C67, 0x4E4F534A, 0x004E4942
_TRIANGLES = 4


@dataclass
class PrimitiveRef:
    """One triangle primitive of one node: where it is and what it is called."""

    node: int
    node_name: str
    mesh: int
    primitive: int
    material: int | None
    matrix: np.ndarray            # (4, 4) node-to-world of the glTF scene


@dataclass
class GltfAsset:
    path: Path
    doc: object                   # the pygltflib.GLTF2 document
    blobs: list[bytes]            # buffers[i] contents
    primitives: list[PrimitiveRef]
    materials: list[GltfMaterial]


def _check_glb(path: Path, data: bytes) -> None:
    """GLB header (magic, version 2, total length) and chunk lengths within the file."""
    if len(data) < 20:
        _fail(path, "glb header", f"file of {len(data)} bytes is shorter than a GLB header")
    magic, version, length = struct.unpack_from("<III", data, 0)
    if magic != _GLB_MAGIC:
        _fail(path, "glb header", "not a GLB file (magic is not 'glTF')")
    if version != 2:
        _fail(path, "glb header", f"GLB version {version}; glTF 2.0 files are version 2")
    if length != len(data):
        _fail(path, "glb header", f"header length {length} bytes but the file has {len(data)}")
    off, k = 12, 0
    while off < len(data):
        if off + 8 > len(data):
            _fail(path, f"glb chunk {k}", "chunk header cut off at the end of the file")
        clen, ctype = struct.unpack_from("<II", data, off)
        if off + 8 + clen > len(data):
            _fail(path, f"glb chunk {k}", f"chunk length {clen} runs past the end of the file")
        if k == 0 and ctype != _JSON_CHUNK:
            _fail(path, "glb chunk 0", "the first chunk is not JSON")
        off += 8 + clen
        k += 1


def _load_document(path: Path):
    import pygltflib
    if not path.is_file():
        _fail(path, None, "glTF file not found")
    suffix = path.suffix.lower()
    if suffix not in (".gltf", ".glb"):
        _fail(path, None, "a glTF file ends in .gltf or .glb")
    try:
        if suffix == ".glb":
            data = path.read_bytes()
            _check_glb(path, data)
            with warnings.catch_warnings():     # unknown chunk types: the buffer check reports
                warnings.simplefilter("ignore")  # a missing BIN chunk where one is needed
                doc = pygltflib.GLTF2.load_from_bytes(data)
        else:
            doc = pygltflib.GLTF2.from_json(path.read_text(encoding="utf-8"))
    except BadInput:
        raise
    except Exception as e:  # noqa: BLE001 - pygltflib raises many types on malformed JSON
        _fail(path, None, f"cannot parse glTF ({type(e).__name__}: "
                          f"{(str(e).splitlines() or [''])[0][:120]})")
    if doc is None or not str(getattr(doc.asset, "version", "") or "").startswith("2."):
        _fail(path, "asset.version", "not a glTF 2.x file")
    for ext in doc.extensionsRequired or []:
        if ext not in SUPPORTED_EXTENSIONS:
            _fail(path, "extensionsRequired", f"requires {ext}, which sgpipe does not "
                  f"implement (it reads: {', '.join(SUPPORTED_EXTENSIONS)})")
    return doc


def _buffers(path: Path, doc) -> list[bytes]:
    out = []
    for i, b in enumerate(doc.buffers or []):
        el = f"buffers[{i}]"
        if b.uri is None:
            data = doc.binary_blob() if i == 0 else None
            if data is None:
                _fail(path, el, "no uri and no GLB binary chunk")
        elif b.uri.startswith("data:"):
            head, _, payload = b.uri.partition(",")
            if not head.endswith(";base64"):
                _fail(path, el, "data URIs must be base64")
            try:
                data = base64.b64decode(payload, validate=True)
            except ValueError:
                _fail(path, el, "data URI is not valid base64")
        else:
            from urllib.parse import unquote
            f = path.parent / unquote(b.uri)
            try:
                data = f.read_bytes()
            except OSError as e:
                _fail(path, el, f"cannot read {f.name} ({e.strerror or e})")
        if len(data) < (b.byteLength or 0):
            _fail(path, el, f"truncated: {len(data)} bytes, byteLength says {b.byteLength}")
        out.append(data)
    return out


def read_accessor(asset: GltfAsset, index: int) -> np.ndarray:
    """Accessor `index` as a float64 (count, width) array (normalized integers scaled to
    [0, 1] / [−1, 1]); every offset is checked against its buffer view and buffer."""
    doc, path = asset.doc, asset.path
    el = f"accessors[{index}]"
    if not 0 <= index < len(doc.accessors or []):
        _fail(path, el, "no such accessor")
    a = doc.accessors[index]
    if a.sparse is not None:
        _fail(path, f"{el}.sparse", "sparse accessors are not supported")
    if a.componentType not in _COMPONENT or a.type not in _WIDTH:
        _fail(path, el, f"unknown componentType {a.componentType} / type {a.type}")
    dt = np.dtype(_COMPONENT[a.componentType]).newbyteorder("<")
    width, count = _WIDTH[a.type], int(a.count)
    if a.bufferView is None:
        return np.zeros((count, width))
    if not 0 <= a.bufferView < len(doc.bufferViews or []):
        _fail(path, f"{el}.bufferView", "no such buffer view")
    bv = doc.bufferViews[a.bufferView]
    if not 0 <= bv.buffer < len(asset.blobs):
        _fail(path, f"bufferViews[{a.bufferView}].buffer", "no such buffer")
    blob = asset.blobs[bv.buffer]
    start = (bv.byteOffset or 0)
    if start + bv.byteLength > len(blob):
        _fail(path, f"bufferViews[{a.bufferView}]", "runs past the end of its buffer")
    elem = dt.itemsize * width
    stride = bv.byteStride or elem
    off = a.byteOffset or 0
    if count and off + stride * (count - 1) + elem > bv.byteLength:
        _fail(path, el, "runs past the end of its buffer view")
    raw = np.frombuffer(blob, np.uint8, count=bv.byteLength, offset=start)[off:]
    rows = np.lib.stride_tricks.as_strided(raw, (count, elem), (stride, 1)) if count else \
        np.zeros((0, elem), np.uint8)
    vals = np.ascontiguousarray(rows).view(dt).reshape(count, width).astype(np.float64)
    if a.normalized and dt.kind in "iu":
        info = np.iinfo(dt)
        vals = np.maximum(vals / info.max, -1.0)
    return vals


def _local_matrix(node) -> np.ndarray:
    if node.matrix is not None and len(node.matrix) == 16:
        return np.asarray(node.matrix, float).reshape(4, 4).T     # column-major in the file
    t = np.asarray(node.translation or (0, 0, 0), float)
    x, y, z, w = np.asarray(node.rotation or (0, 0, 0, 1), float)
    s = np.asarray(node.scale or (1, 1, 1), float)
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])
    m = np.eye(4)
    m[:3, :3] = r * s[None, :]
    m[:3, 3] = t
    return m


def _walk(path: Path, doc) -> list[PrimitiveRef]:
    """Every triangle primitive under the default scene (or scene 0, or every root node)."""
    nodes = doc.nodes or []
    if doc.scenes:
        si = doc.scene if doc.scene is not None else 0
        if not 0 <= si < len(doc.scenes):
            _fail(path, "scene", f"no scene {si}")
        roots = list(doc.scenes[si].nodes or [])
    else:
        children = {c for n in nodes for c in (n.children or [])}
        roots = [i for i in range(len(nodes)) if i not in children]
    out: list[PrimitiveRef] = []
    stack = [(i, np.eye(4), ()) for i in reversed(roots)]
    while stack:
        i, parent, seen = stack.pop()
        if not 0 <= i < len(nodes) or i in seen:
            _fail(path, f"nodes[{i}]", "missing node or a cycle in the node hierarchy")
        node = nodes[i]
        m = parent @ _local_matrix(node)
        if node.mesh is not None:
            if not 0 <= node.mesh < len(doc.meshes or []):
                _fail(path, f"nodes[{i}].mesh", "no such mesh")
            for p, prim in enumerate(doc.meshes[node.mesh].primitives):
                el = f"meshes[{node.mesh}].primitives[{p}]"
                mode = _TRIANGLES if prim.mode is None else prim.mode
                if mode != _TRIANGLES:
                    _fail(path, f"{el}.mode", f"mode {mode}: sgpipe reads triangles (mode 4)")
                if getattr(prim.attributes, "POSITION", None) is None:
                    _fail(path, f"{el}.attributes", "no POSITION")
                out.append(PrimitiveRef(i, node.name or f"node{i}", node.mesh, p, prim.material,
                                        m))
        for c in reversed(node.children or []):
            stack.append((c, m, seen + (i,)))
    return out


#: what a value of the wrong JSON type raises deep in the reading (pygltflib does not check
#: the schema's types): a malformed file, reported as such
_SCHEMA_ERRORS = (TypeError, ValueError, AttributeError, KeyError, IndexError, OverflowError)


def _malformed(path: Path, e: Exception) -> BadInput:
    return BadInput(f"malformed glTF ({type(e).__name__}: "
                    f"{(str(e).splitlines() or [''])[0][:120]})", file=path)


def read_gltf(path: str | Path) -> GltfAsset:
    """Parse and validate a glTF 2.0 file: its buffers, node hierarchy and materials."""
    path = Path(path)
    try:
        doc = _load_document(path)
        blobs = _buffers(path, doc)
        return GltfAsset(path, doc, blobs, _walk(path, doc), read_materials(path, doc))
    except _SCHEMA_ERRORS as e:
        raise _malformed(path, e) from None


def primitive_geometry(asset: GltfAsset, ref: PrimitiveRef) -> dict:
    """World-space (glTF scene) positions, normals, uvs | None (v = 0 at the bottom), tangents
    | None (xyz, w = ±1: the file's TANGENT, else MikkTSpace where the material reads a tangent
    frame) and int64 faces of one primitive; flat-shaded when it has no NORMAL."""
    try:
        return _primitive_geometry(asset, ref)
    except _SCHEMA_ERRORS as e:
        raise _malformed(asset.path, e) from None


def _primitive_geometry(asset: GltfAsset, ref: PrimitiveRef) -> dict:
    path, doc = asset.path, asset.doc
    prim = doc.meshes[ref.mesh].primitives[ref.primitive]
    el = f"meshes[{ref.mesh}].primitives[{ref.primitive}]"
    attr = prim.attributes
    pos = read_accessor(asset, attr.POSITION)
    n_v = len(pos)
    if pos.shape[1] != 3:
        _fail(path, f"{el}.attributes.POSITION", "must be VEC3")

    def optional(name, width):
        idx = getattr(attr, name, None)
        if idx is None:
            return None
        a = read_accessor(asset, idx)
        if a.shape != (n_v, width):
            _fail(path, f"{el}.attributes.{name}", f"{a.shape[0]} × {a.shape[1]} values for "
                  f"{n_v} positions (expected {width} per position)")
        return a

    nrm, uv, tan = optional("NORMAL", 3), optional("TEXCOORD_0", 2), optional("TANGENT", 4)
    if prim.indices is not None:
        idx = read_accessor(asset, prim.indices)
        if idx.shape[1] != 1:
            _fail(path, f"{el}.indices", "must be SCALAR")
        idx = idx[:, 0].astype(np.int64)
    else:
        idx = np.arange(n_v, dtype=np.int64)
    if len(idx) % 3:
        _fail(path, f"{el}.indices", f"{len(idx)} indices is not a whole number of triangles")
    if idx.size and (idx.min() < 0 or idx.max() >= n_v):
        _fail(path, f"{el}.indices", f"index {int(idx.max())} of {n_v} vertices")
    faces = idx.reshape(-1, 3)
    if nrm is None:           # flat: one vertex per corner, the face normal
        pos = pos[faces].reshape(-1, 3)
        uv = None if uv is None else uv[faces].reshape(-1, 2)
        tan = None if tan is None else tan[faces].reshape(-1, 4)
        faces = np.arange(len(pos), dtype=np.int64).reshape(-1, 3)
        tri = pos[faces]
        nrm = np.repeat(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]), 3, axis=0)
    if tan is None and uv is not None and _needs_tangents(asset, ref):
        from sgpipe.io.mikktspace import gltf_primitive_tangents
        pos, nrm, uv, tan, faces = gltf_primitive_tangents(pos, nrm, uv, faces)
    m = ref.matrix
    det = np.linalg.det(m[:3, :3])
    if det < 0:                                             # a mirroring node flips winding
        faces = faces[:, ::-1].copy()
    world = pos @ m[:3, :3].T + m[:3, 3]
    nrm_w = nrm @ np.linalg.inv(m[:3, :3])                  # inverse transpose, row vectors
    if tan is not None:       # bitangent = w (n × t): a mirror turns n × t round, so w too
        tan = np.column_stack([tan[:, :3] @ m[:3, :3].T,
                               np.where(tan[:, 3] < 0, -1.0, 1.0) * np.sign(det)])
    if uv is not None:
        uv = np.column_stack([uv[:, 0], 1.0 - uv[:, 1]])
    return {"positions": world, "normals": nrm_w, "uvs": uv, "tangents": tan, "faces": faces}


def _needs_tangents(asset: GltfAsset, ref: PrimitiveRef) -> bool:
    """Whether the primitive's material reads a tangent frame (a normal texture, anisotropy):
    then a primitive without TANGENT gets MikkTSpace tangents, as the specification asks."""
    if ref.material is None or not 0 <= ref.material < len(asset.materials):
        return False
    m = asset.materials[ref.material]
    return "normalTexture" in m.textures or m.anisotropy > 0.0


def companion_files(path: str | Path) -> list[Path]:
    """The external files a `.gltf` names (buffers, images) beside it: inputs whose change
    must rerun a stage, as the `.gltf` itself does. Empty for a `.glb` or an unreadable file
    (reading it later reports the defect)."""
    import json
    from urllib.parse import unquote
    path = Path(path)
    if path.suffix.lower() != ".gltf":
        return []
    try:
        doc = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return []
    uris = [e.get("uri") for k in ("buffers", "images") for e in doc.get(k) or []
            if isinstance(e, dict)]
    return [path.parent / unquote(u) for u in uris
            if isinstance(u, str) and not u.startswith("data:")
            and (path.parent / unquote(u)).is_file()]


def safe_name(text: str) -> str:
    """A glTF name as an sgpipe object / material name (letters, digits, '_', '-', '.')."""
    s = re.sub(r"[^A-Za-z0-9_.-]+", "_", text.strip()).strip("._") or "unnamed"
    return s if re.match(r"^[A-Za-z0-9_]", s) else "_" + s
