"""The tiny end-to-end config the pipeline tests run through the real CLI (a sphere on a floor,
a Ward and a Lambert material, the studio map; seconds per stage)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

SAMPLES = Path(__file__).resolve().parent.parent / "data_samples"


def tiny_config(methods: str = "[sg, reference]", workers: int | None = None) -> str:
    """YAML text of the tiny scene rendering `methods` (a YAML list)."""
    head = "name: tiny\nseed: 3\n" + (f"workers: {workers}\n" if workers is not None else "")
    return head + f"""scene:
  objects:
    - {{name: ball, sphere_radius: 0.5, translate: [0, 0.5, 0], material: shiny}}
    - {{name: floor, mesh: {SAMPLES / 'floor.obj'}, scale: 0.4, material: matte}}
fit:
  materials:
    - {{name: shiny, model: ward, params: {{alpha: 0.15, kd: [0.2, 0.1, 0.05], ks: 0.6}}}}
    - {{name: matte, model: lambert, params: {{kd: [0.5, 0.5, 0.5]}}}}
  ndf_sg: {{report_lobes: 0}}
  view_gmm: {{lobes: 4, samples: 256, theta_count: 4, report_lobes: 0}}
envmap: {{environment: {SAMPLES / 'studio.exr'}, cube_resolution: 16}}
visibility: {{trace_resolution: 16, resolution: 8, pca_terms: 4, sphere_subdivisions: 2}}
render:
  camera: {{eye: [0, 1.2, 3], target: [0, 0.4, 0], fov_deg: 40, width: 24, height: 16}}
  methods: {methods}
  lights: [{{type: point, position: [1, 3, 1], intensity: [5, 5, 5], radius: 0.1}}]
  spp: 4
  compare_to: reference
"""


def write_floor(path, n: int) -> None:
    """An OBJ grid of n × n vertices over [−1.5, 1.5]² at y = 0, facing +y (the stage tests'
    floor)."""
    x = np.linspace(-1.5, 1.5, n)
    lines = [f"v {a} 0 {b}" for b in x for a in x]
    for i in range(n - 1):
        for j in range(n - 1):
            a = i * n + j + 1
            lines += [f"f {a} {a + n} {a + 1}", f"f {a + 1} {a + n} {a + n + 1}"]
    path.write_text("\n".join(lines) + "\n")
