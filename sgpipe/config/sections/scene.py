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

    def validate(self):
        if (self.mesh is None) == (self.sphere_radius is None):
            raise ValueError("mesh: give exactly one of `mesh` or `sphere_radius`")
        if not all(r > 0 and r < 1e6 for r in self.uv_repeat):
            raise ValueError(f"uv_repeat: each repeat must be in (0, 1e6), got "
                             f"{list(self.uv_repeat)}")
        if self.sphere_radius is not None and tuple(self.uv_repeat) != (1.0, 1.0):
            raise ValueError("uv_repeat: analytic spheres keep their lat-long UVs; use a mesh "
                             "(e.g. a UV sphere OBJ) to tile a texture")


@dataclass
class SceneSection:
    """The static scene."""

    objects: list[ObjectSpec] = doc("Objects in the scene.", default_factory=list)

    def validate(self):
        names = [o.name for o in self.objects]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"objects: duplicate object names {dup}")
