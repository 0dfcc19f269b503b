"""The records the host packs and the kernels read, defined once: the material record (float
slots, Wang09 eq 8–14 parameters and table offsets), the object record (int8 + float4) and the
kernel flag bits. `records_header()` generates `records.h` (MAT_*, OBJ_*(ob), OBJF_*(of),
FLAG_*, VIEW_GMM_*) into the kernel build, as `fh_table.h` is generated.

    rec[KD:KD + 3] = kd                 # material slots as module constants (MaterialSlot)
    objs[k, ObjectSlot.NMAP] = texture  # object slots
"""

from __future__ import annotations

from enum import IntEnum, IntFlag

#: `sg`'s energy tables (render.energy): views, cos θ_o uniform on [ENERGY_COS_MIN, 1].
ENERGY_VIEWS = 32
ENERGY_COS_MIN = 0.01

#: Floats per material record (kernels: `mats + material * MAT_STRIDE`).
MAT_STRIDE = 61


class MaterialSlot(IntEnum):
    """Slot of each material parameter in its float record (kernels: MAT_<name>)."""

    KD = 0            # diffuse colour (RGB, 3 slots)
    KS = 3            # specular colour (RGB)
    GSCALE = 6        # g_scale of M_o
    DIFFUSE = 7       # 0 lambert, 1 ashikhmin_shirley, 2 none, 3 gltf
    FRESNEL = 8       # 0 none, 1 schlick, 2 conductor, 3 dielectric
    F0 = 9            # Schlick F0 (RGB)
    ETA = 12          # index of refraction (RGB)
    K = 15            # conductor absorption (RGB)
    SHADOW = 18       # G2 kind 0..8 (microfacet.h mf_g2)
    AU = 19           # roughness along t
    AV = 20           # roughness along b
    NLOBES = 21       # NDF SG lobes (ndf_sg.npz)
    LOBE0 = 22        # first lobe in the lobe table
    STAB = 23         # offset of the 90-entry shadow table (kind 7) in the table buffer
    GMM = 24          # first row of the view-GMM table (−1: none)
    KDTEX = 25        # texture index of a kd texture (−1: none)
    KSTEX = 26        # texture index of a ks texture (−1: none)
    GMM_NT = 27       # view-GMM grid: θ views
    GMM_NP = 28       # ... φ views
    GMM_K = 29        # ... lobes per view
    GMM_TMAX = 30     # ... largest view θ
    GMM_FLAGS = 31    # ... 1 coherent, 2 includes diffuse
    # A textured glTF material (gltf_pbr with base-colour / metallic-roughness textures): its
    # factors, texture indices and roughness-grid lobes; pixel_init (shading.h) writes each
    # pixel's own record (kd, F0, α, g_scale, lobes) from them.
    BASE = 32         # base colour factor (RGB)
    METAL = 35        # metallic factor
    ROUGH = 36        # roughness factor
    ANISO = 37        # KHR_materials_anisotropy strength (α along t = lerp(α, 1, s²))
    BCTEX = 38        # texture index of the base-colour texture (−1: none)
    MRTEX = 39        # texture index of the metallic-roughness texture (−1: none)
    SVLOB = 40        # first lobe row of the roughness grid's lobe sets (−1: no grid)
    SVN = 41          # roughness grid entries (uniform in ln α from SVA0 to SVA1)
    SVSTEP = 42       # lobe rows per grid entry (its SG lobes + the ASG header row)
    SVA0 = 43         # smallest α of the grid
    SVA1 = 44         # largest α of the grid
    SVFRAC = 45       # a pixel's record: weight of the next grid entry's lobes (0: none)
    SV = 46           # a pixel's record: 1 = per-pixel GGX (exact D analytic, not the table)
    SVLIN = 47        # 1: BCTEX holds (kd, ln roughness) and MRTEX (F0, m) per texel, the
                      # BRDF's linear parameters (filtered as they enter it); 0: the glTF maps
    ETAB = 48         # offset of the material's energy table (render.energy; −1: none)
    ETGRID = 49       # offset of its roughness grid's energy table (views × entries; −1: none)
    WARPN = 50        # 1: sg's warped sub-lobes carry the lobe's exact warped integral (GGX
                      # materials with energy tables: render.energy); 0: the narrow-lobe 1/(o·g)
    AROT = 51         # anisotropy direction: the BRDF frame turned about the shading normal by
                      # this angle (radians) from the tangent towards the bitangent
    EMIT = 52         # emitted radiance (RGB; gltf_pbr `emissive`)
    EMTEX = 55        # texture index of the emissive texture (−1: none), times EMIT
    ANTEX = 56        # texture index of KHR_materials_anisotropy's texture (−1: none): RG the
                      # direction (turns the frame by its angle), B × ANISO the strength
    # gmm's per-pixel mixtures of a textured isotropic gltf_pbr (view_gmm_rough.npz): entries
    # laid out as the GMM block (same θ / φ views and lobes), amplitudes in the F0 basis
    GMR = 57          # first row of the roughness entries' view-GMM blocks (−1: none)
    GMR_N = 58        # entries (uniform in ln α from GMR_A0 to GMR_A1)
    GMR_A0 = 59       # α of the first entry
    GMR_A1 = 60       # α of the last entry


# The packers index a record by these names (the `re` module's idiom for enum members).
globals().update(MaterialSlot.__members__)


class ObjectSlot(IntEnum):
    """Slot of each field of an object's int8 record (kernels: OBJ_<name>(ob))."""

    MAT = 0           # material index
    FACE0 = 1         # first SSDF-mesh face in the face buffer
    VERT0 = 2         # first SSDF-mesh vertex row in the coefficient buffer
    HAS_SSDF = 3      # 1: the object has SSDF data
    BASIS = 4         # offset (floats) of its PCA basis in the SSDF buffer
    MEAN = 5          # offset (floats) of its PCA mean
    RES = 6           # SSDF resolution
    NMAP = 7          # normal-map texture index (−1: none)


class ObjectFloatSlot(IntEnum):
    """Slot of each field of an object's float4 record (kernels: OBJF_<name>(of))."""

    MAXD = 0          # SSDF max_distance (radians)


class KernelFlag(IntFlag):
    """Bits of every shading kernel's `flags` argument (kernels: FLAG_<name>)."""

    NO_ENV_DIFFUSE = 1    # skip the environment's diffuse term
    NO_ENV_SPECULAR = 2   # skip the environment's specular term
    NO_VISIBILITY = 4     # no SSDF shadows (the unshadowed gmm / fis baselines)


class ViewGmmFlag(IntFlag):
    """Bits of a material's MAT_GMM_FLAGS slot (kernels: VIEW_GMM_<name>)."""

    COHERENT = 1          # lobe k matches across views (interpolate lobes)
    INCLUDES_DIFFUSE = 2  # the mixtures fit the whole BRDF slice, diffuse included


def records_header() -> str:
    """C source of `records.h`: the layouts above as macros (vector fields as `.sN` accessors)."""
    lines = ["/* generated by sgpipe.render.records.records_header: host↔kernel record layouts */",
             "#ifndef SGPIPE_RECORDS_H", "#define SGPIPE_RECORDS_H",
             f"#define MAT_STRIDE {MAT_STRIDE}",
             f"#define ENERGY_VIEWS {ENERGY_VIEWS}", f"#define ENERGY_COS_MIN {ENERGY_COS_MIN}f"]
    lines += [f"#define MAT_{s.name} {int(s)}" for s in MaterialSlot]
    lines += [f"#define OBJ_{s.name}(ob) ((ob).s{int(s):x})" for s in ObjectSlot]
    lines += [f"#define OBJF_{s.name}(of) ((of).s{int(s):x})" for s in ObjectFloatSlot]
    lines += [f"#define FLAG_{f.name} {int(f)}" for f in KernelFlag]
    lines += [f"#define VIEW_GMM_{f.name} {int(f)}" for f in ViewGmmFlag]
    return "\n".join(lines + ["#endif", ""])
