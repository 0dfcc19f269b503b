"""glTF 2.0 materials as sgpipe reads them: the metal-rough factors, KHR_materials_anisotropy's
strength, the emission (emissiveFactor × KHR_materials_emissive_strength) and the names of the
textures each material uses (`gltf_pbr` parameters; sgpipe.config.gltf_scene)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from sgpipe.errors import BadInput


def fail(path, element, message):
    """One BadInput naming the glTF file and the element (`materials[2].emissiveFactor`)."""
    raise BadInput(message, file=path, key=element)


@dataclass
class GltfMaterial:
    """A material's metal-rough factors (`gltf_pbr` parameters) and the textures it names."""

    index: int
    name: str
    base_color: tuple[float, float, float]
    metallic: float
    roughness: float
    anisotropy: float
    textures: list[str] = field(default_factory=list)   # e.g. ["baseColorTexture"]
    #: emissiveFactor × KHR_materials_emissive_strength (linear RGB radiance)
    emissive: tuple[float, float, float] = (0.0, 0.0, 0.0)
    #: KHR_materials_anisotropy's anisotropyRotation (radians, from the tangent towards the
    #: bitangent)
    anisotropy_rotation: float = 0.0

    def params(self) -> dict:
        out = {"base_color": list(self.base_color), "metallic": self.metallic,
               "roughness": self.roughness, "anisotropy": self.anisotropy}
        if self.anisotropy_rotation:
            out["anisotropy_rotation"] = self.anisotropy_rotation
        if any(self.emissive):
            out["emissive"] = list(self.emissive)
        return out


def _factor(path, el, v, lo=0.0, hi=1.0):
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not lo <= v <= hi:
        fail(path, el, f"must be a number in [{lo}, {hi}], got {v!r}")
    return float(v)


def read_materials(path: Path, doc) -> list[GltfMaterial]:
    """Every material's metal-rough factors, anisotropy strength and emission, validated (a
    factor out of range is BadInput naming the file and the glTF element)."""
    out = []
    for i, m in enumerate(doc.materials or []):
        el = f"materials[{i}]"
        pbr = m.pbrMetallicRoughness
        base = [1.0, 1.0, 1.0, 1.0] if pbr is None or pbr.baseColorFactor is None \
            else list(pbr.baseColorFactor)
        if len(base) != 4:
            fail(path, f"{el}.pbrMetallicRoughness.baseColorFactor", "needs 4 numbers")
        rgb = tuple(_factor(path, f"{el}.pbrMetallicRoughness.baseColorFactor", c)
                    for c in base[:3])
        metal = _factor(path, f"{el}.pbrMetallicRoughness.metallicFactor",
                        1.0 if pbr is None or pbr.metallicFactor is None else pbr.metallicFactor)
        rough = _factor(path, f"{el}.pbrMetallicRoughness.roughnessFactor",
                        1.0 if pbr is None or pbr.roughnessFactor is None
                        else pbr.roughnessFactor)
        aniso = (m.extensions or {}).get("KHR_materials_anisotropy") or {}
        strength = _factor(path, f"{el}.extensions.KHR_materials_anisotropy.anisotropyStrength",
                           aniso.get("anisotropyStrength", 0.0))
        rotation = _factor(path, f"{el}.extensions.KHR_materials_anisotropy.anisotropyRotation",
                           aniso.get("anisotropyRotation", 0.0), lo=-1e6, hi=1e6)
        emissive = list(m.emissiveFactor or [0.0, 0.0, 0.0])
        if len(emissive) != 3:
            fail(path, f"{el}.emissiveFactor", "needs 3 numbers")
        ext = (m.extensions or {}).get("KHR_materials_emissive_strength") or {}
        strength_e = _factor(path, f"{el}.extensions.KHR_materials_emissive_strength."
                             "emissiveStrength", ext.get("emissiveStrength", 1.0), hi=float("inf"))
        emissive = tuple(strength_e * _factor(path, f"{el}.emissiveFactor", c) for c in emissive)
        textures = [t for t in ("baseColorTexture", "metallicRoughnessTexture")
                    if pbr is not None and getattr(pbr, t, None) is not None]
        textures += [t for t in ("normalTexture", "occlusionTexture", "emissiveTexture")
                     if getattr(m, t, None) is not None]
        if aniso.get("anisotropyTexture"):
            textures.append("KHR_materials_anisotropy.anisotropyTexture")
        out.append(GltfMaterial(i, m.name or f"material{i}", rgb, metal, rough, strength,
                                textures, emissive, rotation))
    return out
