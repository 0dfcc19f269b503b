"""`visibility:` — per-vertex visibility, SSDF and PCA (owned by the visibility stage)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from sgpipe.config.schema import doc


@dataclass
class VisibilitySection:
    """Visibility precomputation for the objects of `scene:` (Wang09 §5)."""

    trace_resolution: int = doc("Concentric-square trace resolution per vertex "
                                "(trace_resolution² occlusion rays per vertex; at most 2048: "
                                "4·10⁶ rays per vertex).", 512, ge=8, le=2048)
    resolution: int = doc("Downsampled visibility/SSDF resolution (must divide "
                          "trace_resolution; at most 512).", 128, ge=4, le=512)
    sampling: Literal["full", "adaptive"] = doc(
        "'full' traces every trace texel (Wang09 §5.2); 'adaptive' traces the texels next "
        "to the projected contour and open edges of the scene, the only places visibility "
        "can change, and fills the regions between them from three probe rays each: the "
        "same image from ~2–3 % of the rays (differs only where Embree leaks through a "
        "shared edge).", "adaptive")
    adaptive_margin: int = doc("Adaptive sampling: the band traced around every projected "
                               "contour or open edge reaches 0.5 + this many trace texels "
                               "to each side (1 is what the bound needs; more only costs "
                               "rays).", 1, ge=1, le=8)
    pca_terms: int = doc("Number of PCA terms N_V (Wang09 eq 24; at most resolution², the "
                         "SSDF's texel count).", 48, ge=1)
    max_distance_deg: float = doc("Clamp of the SSDF magnitude (degrees); also the value "
                                  "of fully occluded hemispheres.", 90.0, gt=0, le=90)
    ray_offset: float = doc("Self-intersection offset along the vertex normal, as a "
                            "fraction of the scene's bounding-box diagonal.", 1e-4, gt=0, lt=0.1)
    chunk_vertices: int = doc("Vertices per parallel work item (bounds memory; at most "
                              "65536).", 128, ge=1, le=65536)
    sphere_subdivisions: int = doc("Icosphere subdivisions for `sphere_radius` objects.",
                                   4, ge=0, le=7)
    power_iterations: int = doc("Power iterations of the randomized streaming PCA.", 3,
                                ge=0, le=10)
    preview_vertices: int = doc("Vertices per object shown in previews/.", 4, ge=0)
    report_vertices: int = doc("Sample vertices per object for the accuracy report.", 6, ge=0)
    report_directions: int = doc("Lobe axes per sample vertex in the accuracy report.", 8,
                                 ge=1)
    report_lambdas: list[float] = doc("SG sharpnesses of the accuracy report (Wang09 Fig 7).",
                                      default_factory=lambda: [2.0, 10.0, 50.0, 200.0, 1000.0])
    report_samples: int = doc("Stratified SG-importance rays per lobe for the ray-traced "
                              "ground truth (rounded to a square).", 4096, ge=16)

    def validate(self):
        if self.trace_resolution % self.resolution:
            raise ValueError(f"resolution: must divide trace_resolution "
                             f"({self.trace_resolution}), got {self.resolution}")
        if self.pca_terms > self.resolution ** 2:
            raise ValueError(f"pca_terms: at most resolution² ({self.resolution ** 2}, the "
                             f"SSDF's texel count), got {self.pca_terms}")
        if any(not (lam > 0) for lam in self.report_lambdas):
            raise ValueError("report_lambdas: every sharpness must be > 0")
