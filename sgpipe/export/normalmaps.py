"""The normalmap stage's filtered products (Han07 §7.3 vMF textures, the engine-roughness
baseline) as 2-D KTX2 and DDS textures with their MIP chains, one file per texture.

Per map `<name>` (docs/HAN07.md "Artifacts"), under `normalmap/<name>/`:
- `vmf_lobeJ.{ktx2,dds}`: RGBA16F, RGB = α_j·r_j (the lobe's weight times its mean resultant
  vector, tangent space), A = α_j: Algorithm 2's vMFTexture[j]; κ_j follows from |r_j|
  (Banerjee), the normal from r_j/|r_j|;
- `roughness.{ktx2,dds}`: R16F, the baseline engine roughness per texel and level.
Row 0 is the top of the texture (v = 1), as in the input map (KTXorientation "rd").
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from sgpipe.artifacts import normalmap as nm_art
from sgpipe.export import dds, ktx2

VMF_TEXT = ("RGB = alpha_j * r_j (lobe weight times mean resultant vector, tangent space: +Z "
            "the geometric normal), A = alpha_j; Han07 Algorithm 2 vMFTexture[j]; rows top "
            "(v = 1) to bottom")
ROUGHNESS_TEXT = "R = engine roughness of the normalmap stage's baseline; rows top (v = 1) down"


def map_names(nm_dir: Path) -> list[str]:
    """Map folders holding vMF textures or baselines, sorted."""
    if not nm_dir.is_dir():
        return []
    return sorted(p.name for p in nm_dir.iterdir()
                  if (p / nm_art.VMF).is_file() or (p / nm_art.BASELINES).is_file())


def _write(staging: Path, stem: str, levels: list[np.ndarray], fmt: ktx2.KtxFormat,
           dxgi: int, text: str) -> list[str]:
    meta = {"sgpipe.content": text}
    (staging / f"{stem}.ktx2").write_bytes(ktx2.write_ktx2(levels, fmt, meta, cube=False))
    (staging / f"{stem}.dds").write_bytes(dds.write_dds(levels, dxgi, cube=False))
    return [f"{stem}.ktx2", f"{stem}.dds"]


def export_normal_maps(nm_dir: Path, staging: Path) -> dict:
    """Write every map's textures under `staging/normalmap/<name>/`; returns {name: files}."""
    out = {}
    for name in map_names(nm_dir):
        folder = staging / "normalmap" / name
        folder.mkdir(parents=True, exist_ok=True)
        files = []
        if (nm_dir / name / nm_art.VMF).is_file():
            v = nm_art.read_vmf(nm_dir, name)
            for j in range(v.alpha[0].shape[2]):
                levels = [np.concatenate([ar[..., j, :], a[..., j:j + 1]], -1)
                          for a, ar in zip(v.alpha, v.alpha_r)]
                files += _write(folder, f"vmf_lobe{j}", levels, ktx2.RGBA16F,
                                dds.DXGI_FORMAT_R16G16B16A16_FLOAT, VMF_TEXT)
        if (nm_dir / name / nm_art.BASELINES).is_file():
            b = nm_art.read_baselines(nm_dir, name)
            files += _write(folder, "roughness", [r[..., None] for r in b["roughness"]],
                            ktx2.R16F, dds.DXGI_FORMAT_R16_FLOAT, ROUGHNESS_TEXT)
        out[name] = [f"normalmap/{name}/{f}" for f in files]
    return out
