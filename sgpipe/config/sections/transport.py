"""`transport:` — Green06 view-dependent precomputed transport (owned by the transport stage)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

from sgpipe.config.schema import doc

#: face resolutions of the light cube (mirrors sgpipe.transport.sampling)
CUBE_RESOLUTIONS = (4, 8, 16, 32, 64)
#: the narrowest Gaussian of `sampling: lobe` (degrees): below a Beckmann α 0.01 mirror lobe
LOBE_SIGMA_MIN_DEG = 0.25


@dataclass
class TransportSection:
    """Per-vertex, per-view transport of the objects of `scene:` fitted with Gaussians
    (Green06 §4). Materials come from `fit.materials` (the objects' `material`)."""

    sampling: Literal["lobe", "cube"] = doc(
        "Where the glossy transport is sampled and how each view's Gaussians are found. "
        "`lobe`: `lobe_samples` directions drawn from each view's specular lobe, shadowed by "
        "traced rays; the view's Gaussians carry the transport's integral about its mean "
        "direction with the L2-closest spread (any lobe width keeps its energy). `cube`: "
        "Green06 as published, the transport at the light cube's texel centres fitted by eq 6 "
        "(Levenberg–Marquardt; 1–3 Gaussians).", "lobe")
    lobe_samples: int = doc("With `sampling: lobe`: specular-lobe directions per vertex and "
                            "view (one occlusion ray each).", 128, ge=8, le=4096)
    cube_resolution: int = doc("Face resolution of the light cubemap (6·res² light texels; "
                               "Green06 used 6×16²): the diffuse SH transfer's visibility, and "
                               "with `sampling: cube` the glossy transport's samples. One of "
                               "4, 8, 16, 32, 64.", 16)
    gaussians: int = doc("Gaussians per vertex per view. `sampling: lobe`: 1 one lobe, 2 a "
                         "core and a wider halo (long-tailed lobes such as GGX), 3 three "
                         "sub-lobes along the lobe's longest direction (oblique views, "
                         "anisotropic BRDFs), 4 those three and a halo. `sampling: cube`: 1–3 "
                         "free Gaussians (Green06 favours 1).", 1, ge=1, le=4)
    alpha: float = doc("Weight α of the data term D (eq 7; each view's term is normalised by "
                       "that view's squared transport, so the weights are unitless).", 1.0,
                       gt=0)
    beta: float = doc("Weight β of the mean coherence term M across neighbouring views "
                      "(eq 8; radians² of mean jumps).", 0.05, ge=0)
    gamma: float = doc("Weight γ of the σ coherence term V across neighbouring views (eq 9).",
                       0.05, ge=0)
    delta: float = doc("Weight δ of the spatial term S against flipped Gaussian pairs at "
                       "processed neighbour vertices (eq 10; with 2–3 Gaussians).", 1.0, ge=0)
    max_iterations: int = doc("Levenberg–Marquardt iterations per vertex at most.", 40,
                              ge=1, le=1000)
    tolerance: float = doc("LM stops when a step lowers the objective by less than this "
                           "fraction (the per-view start phase uses a tenth of it).", 1e-3,
                           gt=0, lt=1)
    sigma_min_deg: float = doc("Smallest Gaussian standard deviation (degrees); 0 = 0.25° with "
                               "`sampling: lobe`, and half a light texel (45°/cube_resolution) "
                               "with `sampling: cube`, the narrowest lobe the light cube "
                               "resolves (a narrower one falls between texel centres and its "
                               "weight is unbounded). Also the low end of the stored σ code.",
                               0.0, ge=0)
    sigma_max_deg: float = doc("Largest Gaussian standard deviation (degrees); the high end of "
                               "the σ code.", 86.0, gt=0, le=180)
    min_view_elevation_deg: float = doc("Views closer than this to a vertex's tangent plane "
                                        "count as below its horizon: they see no projected "
                                        "area, and some BRDFs (Ward) diverge there. With "
                                        "`sampling: cube` they get weight zero; with `lobe` "
                                        "views down to 60° below it take the lobe of their "
                                        "view raised to this elevation (the views around a "
                                        "grazing pixel's view include them).", 1.0, ge=0,
                                        lt=30)
    vertex_materials: bool = doc("Objects in a textured `gltf_pbr` material (base-colour or "
                                 "metallic-roughness texture, isotropic): fit each vertex's "
                                 "glossy transport with its own BRDF, the textures filtered to "
                                 "the vertex spacing (Green06 Fig 1's spatially varying "
                                 "material). false: every vertex takes the material's factors.",
                                 True)
    vertex_limit: int = doc("Largest vertex count per object; a larger mesh is bad input "
                            "(the cost grows with vertices × 92 views × light texels).", 50000,
                            ge=1)
    indirect: bool = doc("Add the indirect transport (Green06 §4.1 eq 5): the indirect glossy "
                         "part T^IG by BRDF-importance-sampled paths along each view, and the "
                         "interreflected SH transfer (sgpipe.transport.sampling / sh_transfer), "
                         "RGB since the bounces take the surfaces' colours. Each vertex draws "
                         "from its own random stream (seed, object, vertex).", False)
    indirect_bounces: int = doc("With `indirect`: surfaces a path may meet after the vertex "
                                "before it must leave the scene (absorbed otherwise), as "
                                "`render.reference_bounces`.", 2, ge=1, le=8)
    indirect_paths: int = doc("With `indirect`: paths per vertex and view for T^IG (drawn "
                              "from the specular lobe, stratified in u1).", 128, ge=1,
                              le=65536)
    indirect_transfer_paths: int = doc("With `indirect`: paths per occluded light texel for "
                                       "the interreflected SH transfer.", 4, ge=1, le=4096)
    ray_offset: float = doc("Self-intersection offset along the normal, as a fraction of the "
                            "scene's bounding-box diagonal (as `visibility.ray_offset`).", 1e-4,
                            gt=0, lt=0.1)
    chunk_vertices: int = doc("Vertices per parallel work item; with `flood_fill: chunk` "
                              "the flood fill (fit started from a fitted neighbour) runs "
                              "within a chunk, so the chunking, never the worker count, "
                              "decides the result. At most 4096: "
                              "a chunk holds its vertices' light-cube visibility (6·res² "
                              "texels each) and 92-view fits.", 256, ge=1, le=4096)
    flood_fill: Literal["chunk", "mesh"] = doc(
        "With `sampling: cube`, which fitted neighbours seed a vertex's eq 6 fit and its "
        "spatial term. `chunk`: those of its own chunk (`chunk_vertices`; chunks run in "
        "parallel). `mesh`: Green06 §4.2 as published, one flood fill over the whole mesh — "
        "any neighbour fitted before it, in whichever chunk — so the chunks run one after "
        "another. `sampling: lobe` fits every vertex from its own samples.", "chunk")
    sphere_subdivisions: int = doc("Icosphere subdivisions for `sphere_radius` objects.", 3,
                                   ge=0, le=7)
    report_vertices: int = doc("Vertices per object whose compact-vs-full error is measured "
                               "for the report.", 64, ge=0)

    def sigma_min_resolved_deg(self) -> float:
        """`sigma_min_deg`, or when it is 0: half a light texel with `sampling: cube`,
        LOBE_SIGMA_MIN_DEG with `sampling: lobe`."""
        if self.sigma_min_deg:
            return self.sigma_min_deg
        return LOBE_SIGMA_MIN_DEG if self.sampling == "lobe" else 45.0 / self.cube_resolution

    def validate(self):
        if self.cube_resolution not in CUBE_RESOLUTIONS:
            raise ValueError(f"cube_resolution: must be one of {list(CUBE_RESOLUTIONS)}, got "
                             f"{self.cube_resolution}")
        if self.sampling == "cube" and self.gaussians > 3:
            raise ValueError("gaussians: `sampling: cube` fits 1–3 Gaussians per view")
        if not self.sigma_min_resolved_deg() < self.sigma_max_deg:
            raise ValueError("sigma_max_deg: must be larger than sigma_min_deg")
