"""`scene:` — objects shared by the visibility and render stages."""

from __future__ import annotations

from dataclasses import dataclass

from sgpipe.config.schema import InputPath, doc


@dataclass
class ObjectSpec:
    """One object: a mesh file or an analytic sphere, a transform and a material name."""

    name: str = doc("Unique object name.")
    mesh: InputPath | None = doc("Mesh file (OBJ/PLY/GLB) loaded with trimesh.", None)
    sphere_radius: float | None = doc("Analytic sphere of this radius (instead of `mesh`).",
                                      None, gt=0)
    translate: tuple[float, float, float] = doc("Translation (world units).", (0.0, 0.0, 0.0))
    rotate_deg: tuple[float, float, float] = doc("Rotation about X, then Y, then Z (degrees).",
                                                 (0.0, 0.0, 0.0))
    scale: float = doc("Uniform scale.", 1.0, gt=0)
    material: str = doc("Name of a material in `fit.materials`.", "default")
    normal_map: InputPath | None = doc("Tangent-space normal map (optional).", None)
    uv_repeat: tuple[float, float] = doc(
        "Tiling of the object's textures (normal map, kd / ks maps): the mesh's UVs are "
        "multiplied by (u, v) (Han07 §3.2 tiles its normal maps). Meshes only.", (1.0, 1.0))
    gltf_node: int | None = doc(
        "With a .gltf / .glb `mesh`: only this node's mesh (its index in the file's `nodes`), "
        "placed by the node's world transform, then by translate / rotate_deg / scale. Unset: "
        "every primitive of the file's scene.", None, ge=0)
    gltf_primitive: int | None = doc(
        "With gltf_node: only this primitive of the node's mesh (unset: all of them).", None,
        ge=0)

    def validate(self):
        if (self.mesh is None) == (self.sphere_radius is None):
            raise ValueError("mesh: give exactly one of `mesh` or `sphere_radius`")
        is_gltf = self.mesh is not None and str(self.mesh).lower().endswith((".gltf", ".glb"))
        if self.gltf_node is not None and not is_gltf:
            raise ValueError("gltf_node: only for a .gltf / .glb mesh")
        if self.gltf_primitive is not None and self.gltf_node is None:
            raise ValueError("gltf_primitive: needs gltf_node")
        if not all(r > 0 and r < 1e6 for r in self.uv_repeat):
            raise ValueError(f"uv_repeat: each repeat must be in (0, 1e6), got "
                             f"{list(self.uv_repeat)}")
        if self.sphere_radius is not None and tuple(self.uv_repeat) != (1.0, 1.0):
            raise ValueError("uv_repeat: analytic spheres keep their lat-long UVs; use a mesh "
                             "(e.g. a UV sphere OBJ) to tile a texture")


@dataclass
class GltfSceneSpec:
    """A glTF 2.0 file brought in whole: one object per triangle primitive, one `gltf_pbr`
    material per glTF material (its factors), named `<prefix>.<node>.<primitive>` and
    `<prefix>.<material>`."""

    file: InputPath = doc("The .gltf (with its buffers beside it) or .glb file.")
    nodes: list[str] = doc("Node names to bring in, each with its descendants (empty: the "
                           "file's whole scene).", default_factory=list)
    prefix: str | None = doc("Name prefix of its objects and materials (default: the file's "
                             "stem).", None)
    translate: tuple[float, float, float] = doc("Translation applied after the file's own "
                                                "node transforms.", (0.0, 0.0, 0.0))
    rotate_deg: tuple[float, float, float] = doc("Rotation about X, then Y, then Z (degrees), "
                                                 "after the node transforms.", (0.0, 0.0, 0.0))
    scale: float = doc("Uniform scale after the node transforms.", 1.0, gt=0)


@dataclass
class SceneSection:
    """The static scene."""

    objects: list[ObjectSpec] = doc("Objects in the scene (glTF files' objects are appended "
                                    "to these when the config is loaded).",
                                    default_factory=list)
    gltf: list[GltfSceneSpec] = doc("glTF 2.0 files whose primitives and materials join the "
                                    "scene (docs/CONVENTIONS.md: glTF assets).",
                                    default_factory=list)

    def validate(self):
        names = [o.name for o in self.objects]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"objects: duplicate object names {dup}")
