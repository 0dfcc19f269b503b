"""glTF 2.0 (pygltflib): the visibility objects as meshes carrying their SSDF PCA coefficients
(Wang09 eq 24) as custom vertex attributes `_SSDF_PCA0…`, and the environment as an
EXT_lights_image_based light (SH9 irradiance, RGBD PNG specular cube faces per mip).

Attribute layout (docs/EXPORT.md): `_SSDF_PCA{j}` is a float VEC4 holding coefficients
4j … 4j+3 of the vertex (zeros past the last term); the mean and eigen-images are float SCALAR
accessors named in the mesh's `extras.sgpipe_ssdf`, row-major (term, row, column).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pygltflib as gl

from sgpipe.io.gltf_buffer import GltfBuffer

EXTENSION = "EXT_lights_image_based"
RGBD_MAX_RANGE = 255.0      # Babylon.js RGBD: D = floor(min(255/max, 255))/255, gamma 2.2
RGBD_GAMMA = 2.2


@dataclass
class VertexObject:
    """One visibility object as glTF needs it (float32 arrays, vertex order of geometry.npz)."""

    name: str
    positions: np.ndarray       # (V, 3)
    normals: np.ndarray         # (V, 3)
    faces: np.ndarray           # (F, 3)
    tangents: np.ndarray | None  # (V, 3), b = n × t
    uvs: np.ndarray | None       # (V, 2), OBJ convention (v = 0 at the bottom)
    ssdf_coeffs: np.ndarray     # (V, T)
    ssdf_mean: np.ndarray       # (R, R)
    ssdf_basis: np.ndarray      # (T, R, R)
    max_distance: float


def rgbd_encode(rgb: np.ndarray) -> np.ndarray:
    """Linear RGB (..., 3) → RGBD uint8 (..., 4) as Babylon.js writes it (the extension's
    reference runtime): D = clamp(floor(max(255/m, 1))/255, 0, 1) with m = max channel,
    rgb' = (rgb·D)^(1/2.2); values above 255 clip."""
    rgb = np.maximum(np.asarray(rgb, np.float64), 0.0)
    m = np.maximum(rgb.max(-1, keepdims=True), 1e-12)
    d = np.clip(np.floor(np.maximum(RGBD_MAX_RANGE / m, 1.0)) / 255.0, 0.0, 1.0)
    enc = np.clip(rgb * d, 0.0, 1.0) ** (1.0 / RGBD_GAMMA)
    return np.rint(np.concatenate([enc, d], -1) * 255.0).astype(np.uint8)


def rgbd_decode(rgbd: np.ndarray) -> np.ndarray:
    """RGBD uint8 (..., 4) → linear RGB: (rgb/255)^2.2 / (a/255)."""
    x = np.asarray(rgbd, np.float64) / 255.0
    return x[..., :3] ** RGBD_GAMMA / np.maximum(x[..., 3:], 1.0 / 255.0)


def face_image(face: np.ndarray) -> np.ndarray:
    """A (n, n, 3) face in sgpipe's cube convention → the RGBD image the extension stores,
    "flipped about its vertical axis" (the extension text: columns mirrored)."""
    return rgbd_encode(face[:, ::-1])


def ssdf_attribute_names(terms: int) -> list[str]:
    return [f"_SSDF_PCA{j}" for j in range(math.ceil(terms / 4))]


def _mesh(b: GltfBuffer, obj: VertexObject) -> gl.Mesh:
    f32 = np.float32
    attrs = gl.Attributes(
        POSITION=b.accessor(obj.positions.astype(f32), gl.VEC3, gl.ARRAY_BUFFER, minmax=True),
        NORMAL=b.accessor(obj.normals.astype(f32), gl.VEC3, gl.ARRAY_BUFFER))
    if obj.tangents is not None:       # glTF: bitangent = cross(normal, tangent.xyz) · w
        t4 = np.concatenate([obj.tangents, np.ones((len(obj.tangents), 1))], 1)
        attrs.TANGENT = b.accessor(t4.astype(f32), gl.VEC4, gl.ARRAY_BUFFER)
    if obj.uvs is not None:            # glTF's v runs down the image, OBJ's up
        uv = np.stack([obj.uvs[:, 0], 1.0 - obj.uvs[:, 1]], 1)
        attrs.TEXCOORD_0 = b.accessor(uv.astype(f32), gl.VEC2, gl.ARRAY_BUFFER)
    terms = obj.ssdf_coeffs.shape[1]
    names = ssdf_attribute_names(terms)
    padded = np.zeros((len(obj.ssdf_coeffs), 4 * len(names)), f32)
    padded[:, :terms] = obj.ssdf_coeffs
    for j, name in enumerate(names):
        setattr(attrs, name, b.accessor(padded[:, 4 * j:4 * j + 4], gl.VEC4, gl.ARRAY_BUFFER))
    indices = b.accessor(obj.faces.astype(np.uint32).reshape(-1), gl.SCALAR,
                         gl.ELEMENT_ARRAY_BUFFER)
    r = obj.ssdf_mean.shape[0]
    extras = {"sgpipe_ssdf": {
        "terms": terms, "attributes": names, "resolution": r,
        "max_distance": obj.max_distance,
        "mean_accessor": b.accessor(obj.ssdf_mean.astype(f32).reshape(-1), gl.SCALAR, None),
        "basis_accessor": b.accessor(obj.ssdf_basis.astype(f32).reshape(-1), gl.SCALAR, None),
        "reconstruction": "S[r][c] = mean[r*R + c] + sum_j coeff_j * basis[(j*R + r)*R + c], "
                          "clamped to +-max_distance (radians); coeff_j = _SSDF_PCA{j//4}"
                          "[j%4]; the R x R grid and frame: docs/ARTIFACTS.md visibility/"}}
    return gl.Mesh(name=obj.name, extras=extras, primitives=[
        gl.Primitive(attributes=attrs, indices=indices, mode=gl.TRIANGLES)])


def _add_green06(b: GltfBuffer, prim: gl.Primitive, mesh: gl.Mesh, t) -> None:
    """Green06's attributes on `prim` and its tables in `mesh.extras.sgpipe_green06`."""
    from sgpipe.export import green06
    for name, (arr, kind) in green06.vertex_attributes(t).items():
        setattr(prim.attributes, name, b.accessor(arr, kind, gl.ARRAY_BUFFER))
    acc = {name: b.accessor(arr if kind != "SCALAR" else arr.reshape(-1), kind, None)
           for name, (arr, kind) in green06.tables(t).items()}
    mesh.extras = {**(mesh.extras or {}), "sgpipe_green06": green06.extras(t, acc)}


def _green06_mesh(b: GltfBuffer, t) -> gl.Mesh:
    """A mesh of its own for a transport object whose vertices are not a visibility mesh's."""
    f32 = np.float32
    attrs = gl.Attributes(
        POSITION=b.accessor(t.positions.astype(f32), gl.VEC3, gl.ARRAY_BUFFER, minmax=True),
        NORMAL=b.accessor(t.normals.astype(f32), gl.VEC3, gl.ARRAY_BUFFER))
    indices = b.accessor(t.faces.astype(np.uint32).reshape(-1), gl.SCALAR,
                         gl.ELEMENT_ARRAY_BUFFER)
    return gl.Mesh(name=t.name, primitives=[gl.Primitive(attributes=attrs, indices=indices,
                                                         mode=gl.TRIANGLES)])


def build_gltf(objects: list[VertexObject], *, irradiance: np.ndarray,
               specular_uris: list[list[str]], specular_size: int,
               bin_uri: str, transport: list | None = None,
               rotation: np.ndarray | None = None) -> tuple[gl.GLTF2, bytes]:
    """The glTF document and its binary buffer: one node per object (a transport object whose
    vertices are a visibility object's shares its mesh), a scene with the IBL. `rotation`
    (world ← the cube's frame: render.environment_rotation times the export orientation's
    turn) becomes the light's `rotation`; `irradiance` and the specular images are in the
    cube's frame (the runtime turns them by it)."""
    doc = gl.GLTF2(asset=gl.Asset(version="2.0", generator="sgpipe export"))
    b = GltfBuffer(doc)
    for obj in objects:
        doc.meshes.append(_mesh(b, obj))
        doc.nodes.append(gl.Node(name=obj.name, mesh=len(doc.meshes) - 1))
    by_name = {o.name: (o, m) for o, m in zip(objects, doc.meshes)}
    for t in transport or []:
        obj, mesh = by_name.get(t.name, (None, None))
        if obj is None or obj.positions.shape != t.positions.shape or not np.array_equal(
                obj.positions.astype(np.float32), t.positions.astype(np.float32)):
            mesh = _green06_mesh(b, t)
            doc.meshes.append(mesh)
            doc.nodes.append(gl.Node(name=f"{t.name} (transport)", mesh=len(doc.meshes) - 1))
        _add_green06(b, mesh.primitives[0], mesh, t)
    for row in specular_uris:
        for uri in row:
            doc.images.append(gl.Image(uri=uri, mimeType="image/png"))
    ids, k = [], 0
    for row in specular_uris:
        ids.append(list(range(k, k + len(row))))
        k += len(row)
    doc.extensionsUsed = [EXTENSION]
    light = {"name": "environment", "intensity": 1.0, "rotation": [0.0, 0.0, 0.0, 1.0],
             "irradianceCoefficients": np.asarray(irradiance, float).reshape(9, 3).tolist(),
             "specularImageSize": int(specular_size), "specularImages": ids}
    if rotation is not None:
        from sgpipe.export.env_rotation import gltf_quaternion, rotate_sh9
        light["rotation"] = gltf_quaternion(rotation)
        # for runtimes that ignore `rotation`: the coefficients already turned (world frame)
        light["extras"] = {"sgpipe_world_irradiance": rotate_sh9(
            light["irradianceCoefficients"], rotation).tolist()}
    doc.extensions = {EXTENSION: {"lights": [light]}}
    doc.scenes.append(gl.Scene(nodes=list(range(len(doc.nodes))),
                               extensions={EXTENSION: {"light": 0}}))
    doc.scene = 0
    b.blob += b"\0" * (-len(b.blob) % 4)
    doc.buffers.append(gl.Buffer(byteLength=len(b.blob), uri=bin_uri))
    return doc, bytes(b.blob)
