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

    def validate(self):
        if (self.mesh is None) == (self.sphere_radius is None):
            raise ValueError("mesh: give exactly one of `mesh` or `sphere_radius`")


@dataclass
class SceneSection:
    """The static scene."""

    objects: list[ObjectSpec] = doc("Objects in the scene.", default_factory=list)

    def validate(self):
        names = [o.name for o in self.objects]
        dup = sorted({n for n in names if names.count(n) > 1})
        if dup:
            raise ValueError(f"objects: duplicate object names {dup}")
