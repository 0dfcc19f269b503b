"""Material artifacts (`<out>/fit/<material>/`, docs/ARTIFACTS.md fit/) → the float records,
SG lobe table and side tables the kernels read (layout: kernels/include/microfacet.h).

One `Material` per `fit.materials` entry: the microfacet factor M_o (microfacet.npz), the NDF
SG lobes D* (ndf_sg.npz, Wang09 eq 12/16), optionally the per-view vMF mixtures (view_gmm.npz,
Töral19 eq 3) and a tabulated exact NDF D(h) for filtered importance sampling.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from sgpipe.artifacts import fit as contract
from sgpipe.artifacts import scalar
from sgpipe.brdf.models import GLTF_MIN_ROUGHNESS
from sgpipe.core.asg import x_angle
from sgpipe.errors import BadInput
from sgpipe.render.records import (ANISO, ANTEX, AROT, AU, AV, BASE, BCTEX, DIFFUSE, EMIT,
                                   EMTEX, ETA, ETAB, ETGRID, F0, FRESNEL, GMM, GMR, GMR_A0,
                                   GMR_A1, GMR_N, WARPN, GMM_FLAGS, GMM_K, GMM_NP, GMM_NT,
                                   GMM_TMAX, GSCALE, K, KD,
                                   KDTEX, KS, KSTEX, LOBE0, MAT_STRIDE, METAL, MRTEX, NLOBES,
                                   ROUGH, SHADOW, STAB, SVA0, SVA1, SVLIN, SVLOB, SVN,
                                   SVSTEP)

# The exact-NDF table (fis) is located through a separate int4 per material (offset, nt, np, 0).

#: Exact-NDF table resolution: rows t = sqrt(1 − cos θ_h) ∈ [0, 1], columns φ_h ∈ [0, 2π).
NDF_TABLE_T = 1024
NDF_TABLE_P_ANISO = 64


@dataclass
class GltfFactors:
    """A textured gltf_pbr material as the kernels rebuild it per pixel (shading.h
    pixel_init): factor × texel for base colour (sRGB-decoded), roughness (G) and metallic (B);
    texture indices into the renderer's `Textures` (−1: none)."""

    base_color: np.ndarray
    metallic: float
    roughness: float
    anisotropy: float = 0.0
    base_texture: int = -1
    metal_rough_texture: int = -1
    linear: bool = False    # the textures hold (kd, roughness) and (F0, m): linear_parameters
    #: KHR_materials_anisotropy's texture: RG its direction in the tangent frame (2c − 1, from
    #: t towards the handed bitangent, then turned by the rotation), B × the strength
    anisotropy_texture: int = -1

    @classmethod
    def of_params(cls, p: dict) -> "GltfFactors":
        """The factors of a gltf_pbr material's params (glTF's defaults: 1), no textures."""
        return cls(np.broadcast_to(np.asarray(p.get("base_color", 1.0), float), (3,)),
                   float(p.get("metallic", 1.0)), float(p.get("roughness", 1.0)),
                   float(p.get("anisotropy", 0.0)))


@dataclass
class Material:
    """Everything one material contributes to the kernels."""

    name: str
    kd: np.ndarray = field(default_factory=lambda: np.zeros(3))
    ks: np.ndarray = field(default_factory=lambda: np.zeros(3))
    g_scale: float = 1.0
    diffuse: int = 0
    fresnel: int = 0
    f0: np.ndarray = field(default_factory=lambda: np.zeros(3))
    eta: np.ndarray = field(default_factory=lambda: np.zeros(3))
    k: np.ndarray = field(default_factory=lambda: np.zeros(3))
    shadowing: int = 0
    alpha_u: float = 0.0
    alpha_v: float = 0.0
    shadow_table: np.ndarray = field(default_factory=lambda: np.ones(90))
    # NDF SG lobes: axis (L,3) local, sharpness (L,), amplitude (L,)
    lobe_axis: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    lobe_lambda: np.ndarray = field(default_factory=lambda: np.zeros(0))
    lobe_mu: np.ndarray = field(default_factory=lambda: np.zeros(0))
    # NDF ASG lobes (ndf_asg.npz; used by `sg` instead of the SG lobes when present)
    asg_z: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    asg_x: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    asg_lambda: np.ndarray = field(default_factory=lambda: np.zeros(0))
    asg_mu: np.ndarray = field(default_factory=lambda: np.zeros(0))
    asg_amp: np.ndarray = field(default_factory=lambda: np.zeros(0))
    gmm: dict | None = None          # view_gmm.npz arrays
    gmm_toral19: dict | None = None  # view_gmm_toral19.npz arrays (Töral19's published fit)
    gmm_rough: dict | None = None    # view_gmm_rough.npz arrays (gmm's per-pixel mixtures)
    ndf_table: np.ndarray | None = None  # (nt, np) exact D on the (t, φ) grid (fis)
    kd_texture: int = -1
    ks_texture: int = -1
    gltf: "GltfFactors | None" = None    # a textured gltf_pbr material (per-pixel parameters)
    rough_grid: object | None = None     # ndf_sg_rough.npz (artifacts.fit.RoughLobes)
    energy: np.ndarray | None = None     # sg's energy table (ENERGY_VIEWS,) (render.energy)
    energy_grid: np.ndarray | None = None  # ... per roughness-grid entry (ENERGY_VIEWS, R, 4)
    exact_warp: bool = False             # sg's exact warped lobe mass (render.energy, WARPN)
    emission: np.ndarray = field(default_factory=lambda: np.zeros(3))   # emitted radiance
    emission_texture: int = -1           # its texture (× emission), −1: none
    #: the anisotropy direction: the BRDF frame turned about the shading normal by this angle
    #: (radians) from the tangent towards the bitangent (gltf_pbr `anisotropy_rotation`)
    frame_rotation: float = 0.0

    @classmethod
    def lambert(cls, name: str, kd) -> "Material":
        return cls(name, kd=np.broadcast_to(np.asarray(kd, float), (3,)).copy())

    @classmethod
    def load(cls, folder: str | Path, name: str, *, need_gmm: bool = False,
             need_gmm_toral19: bool = False) -> "Material":
        """Read `<out>/fit/<name>/` (microfacet.npz, ndf_sg.npz, view_gmm.npz and
        view_gmm_toral19.npz if needed) with the readers of sgpipe.artifacts.fit."""
        folder = Path(folder)
        if not folder.is_dir():
            raise BadInput(f"fitted material {name!r} not found (run `sgpipe fit` first)",
                           file=folder, key="fit.materials")
        mf = contract.read_microfacet(folder, name)
        ndf = contract.read_ndf_sg(folder, name)
        asg = contract.read_ndf_asg(folder, name)
        m = cls(name, kd=mf.kd, ks=mf.ks, g_scale=mf.g_scale, diffuse=mf.diffuse,
                   fresnel=mf.fresnel, f0=mf.f0, eta=mf.eta, k=mf.k, shadowing=mf.shadowing,
                   alpha_u=mf.alpha_u, alpha_v=mf.alpha_v, shadow_table=mf.shadow_table,
                   lobe_axis=ndf.axis, lobe_lambda=ndf.sharpness, lobe_mu=ndf.amplitude,
                   gmm=contract.read_view_gmm(folder, name) if need_gmm else None)
        if need_gmm_toral19:
            if not (folder / contract.VIEW_GMM_TORAL19).is_file():
                raise BadInput("Töral19's published mixtures are missing (run `sgpipe fit` with "
                               "gmm_toral19 in render.methods)",
                               file=folder / contract.VIEW_GMM_TORAL19, key="render.methods")
            m.gmm_toral19 = contract.read_view_gmm(folder, name, name=contract.VIEW_GMM_TORAL19)
        if asg is not None:
            m.set_asg(asg.z, asg.x, asg.sharpness_x, asg.sharpness_y, asg.amplitude)
        m.rough_grid = contract.read_ndf_sg_rough(folder, name)
        if need_gmm:
            m.gmm_rough = contract.read_view_gmm_rough(folder, name)
        return m

    def set_asg(self, z, x, lam, mu, amp) -> None:
        """NDF ASG lobes (Xu13 eq 4) in the local frame: axes z (L,3), sharp axes x (L,3)."""
        self.asg_z = np.asarray(z, float).reshape(-1, 3)
        self.asg_x = np.asarray(x, float).reshape(-1, 3)
        self.asg_lambda = np.asarray(lam, float).reshape(-1)
        self.asg_mu = np.asarray(mu, float).reshape(-1)
        self.asg_amp = np.asarray(amp, float).reshape(-1)

    @classmethod
    def from_brdf(cls, name: str, brdf, lobes=None) -> "Material":
        """From a `sgpipe.brdf` BRDF: its microfacet parameters and either the given NDF lobes
        [(axis, λ, μ), ...] or the single analytic SG lobe of its NDF (Wang09 eq 12)."""
        p = brdf.microfacet_params()
        m = cls(name, kd=np.asarray(p["kd"], float), ks=np.asarray(p["ks"], float),
                g_scale=float(p["g_scale"]), diffuse=int(p["diffuse"]), fresnel=int(p["fresnel"]),
                f0=np.asarray(p["f0"], float), eta=np.asarray(p["eta"], float),
                k=np.asarray(p["k"], float), shadowing=int(p["shadowing"]),
                alpha_u=float(p["alpha_u"]), alpha_v=float(p["alpha_v"]),
                shadow_table=np.asarray(p["shadow_table"], float))
        if lobes is None and getattr(brdf, "ndf_model", None) is not None:
            sg = brdf.ndf_model.sg_analytic()
            lobes = [((0.0, 0.0, 1.0), sg[0], sg[1])] if sg is not None else []
        lobes = list(lobes or [])
        m.lobe_axis = np.array([a for a, _, _ in lobes], float).reshape(-1, 3)
        m.lobe_lambda = np.array([lam for _, lam, _ in lobes], float)
        m.lobe_mu = np.array([mu for _, _, mu in lobes], float)
        return m

    def tabulate_ndf(self, brdf) -> None:
        """Exact D(h) of a `sgpipe.brdf` BRDF on the (t = √(1 − cos θ_h), φ_h) grid (fis)."""
        nt = NDF_TABLE_T
        npp = 1 if getattr(brdf, "isotropic", True) else NDF_TABLE_P_ANISO
        t = np.linspace(0.0, 1.0, nt)
        phi = np.arange(npp) * (2 * np.pi / npp)
        cos_t = 1.0 - t[:, None] ** 2
        sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t ** 2))
        h = np.stack(np.broadcast_arrays(sin_t * np.cos(phi), sin_t * np.sin(phi), cos_t), -1)
        self.ndf_table = np.asarray(brdf.ndf(h), np.float32).reshape(nt, npp)


@dataclass
class MaterialTable:
    """Packed materials: records (M, MAT_STRIDE), lobes (L, 2, 4), tables (float), gmm (float4)."""

    names: list[str]
    records: np.ndarray
    lobes: np.ndarray
    tables: np.ndarray
    gmm: np.ndarray
    ndf_info: np.ndarray     # (M, 4) int32: offset into tables, nt, np, has
    max_lobes: int
    max_gmm_lobes: int

    def index(self, name: str) -> int:
        return self.names.index(name)


def _gmm_block(g: dict):
    """view_gmm arrays → (header values, float4 rows): per (view j, lobe k) two float4:
    (alpha RGB, kappa), (mu_theta, mu_phi, 0, 0)."""
    th = np.asarray(g["view_theta"], float)
    ph = np.asarray(g["view_phi"], float)
    alpha = np.asarray(g["alpha"], float)
    J, Kl = alpha.shape[:2]
    rows = np.zeros((J, Kl, 2, 4), np.float32)
    rows[..., 0, :3] = alpha
    rows[..., 0, 3] = np.asarray(g["kappa"], float)
    rows[..., 1, 0] = np.asarray(g["mu_theta"], float)
    rows[..., 1, 1] = np.asarray(g["mu_phi"], float)
    flags = int(scalar(g["coherent"])) + 2 * int(scalar(g["includes_diffuse"]))
    return (len(th), len(ph), Kl, float(th[-1]) if len(th) else 0.0, flags), rows.reshape(-1, 4)


def _gmm_rough_blocks(g: dict, gmm: dict | None):
    """view_gmm_rough arrays → (entries, α first, α last, float4 rows): each entry's block as
    _gmm_block lays out view_gmm's, entry after entry; None unless the material's own view_gmm
    has the same views and lobe count (the kernel reads both with its header)."""
    rough = np.asarray(g["roughness"], float)
    if gmm is None or np.shape(gmm["alpha"])[1:] != np.shape(g["alpha"])[2:] \
            or np.size(gmm["view_theta"]) != np.size(g["view_theta"]) \
            or np.size(gmm["view_phi"]) != np.size(g["view_phi"]):
        return None
    rows = []
    for e in range(len(rough)):
        one = {k: g[k][e] for k in ("alpha", "kappa", "mu_theta", "mu_phi")}
        one.update(view_theta=g["view_theta"], view_phi=g["view_phi"],
                   coherent=g["coherent"], includes_diffuse=0)
        rows.append(_gmm_block(one)[1])
    a = np.maximum(rough, GLTF_MIN_ROUGHNESS) ** 2
    return len(rough), float(a[0]), float(a[-1]), np.concatenate(rows)


def pack_materials(materials: list[Material]) -> MaterialTable:
    """Pack materials in list order (index = material id used by object records)."""
    recs = np.zeros((max(len(materials), 1), MAT_STRIDE), np.float32)
    # texture and table indices: none (the one record of an empty table is a blank material)
    recs[:, [GMM, KDTEX, KSTEX, BCTEX, MRTEX, SVLOB, ETAB, ETGRID, EMTEX, ANTEX, GMR]] = -1
    lobes, tables, gmm = [], [], []
    ndf_info = np.zeros((max(len(materials), 1), 4), np.int32)
    n_lobe = n_tab = n_gmm = 0
    max_lobes = max_k = 1
    for i, m in enumerate(materials):
        r = recs[i]
        r[KD:KD + 3], r[KS:KS + 3] = m.kd, m.ks
        r[GSCALE], r[DIFFUSE], r[FRESNEL], r[SHADOW] = m.g_scale, m.diffuse, m.fresnel, m.shadowing
        r[F0:F0 + 3], r[ETA:ETA + 3], r[K:K + 3] = m.f0, m.eta, m.k
        r[AU], r[AV] = m.alpha_u, m.alpha_v
        nl = len(m.lobe_lambda) if np.any(np.asarray(m.ks) > 0) else 0
        r[NLOBES], r[LOBE0] = nl, n_lobe
        for a, lam, mu in zip(m.lobe_axis[:nl], m.lobe_lambda[:nl], m.lobe_mu[:nl]):
            lobes.append([[*(np.asarray(a) / np.linalg.norm(a)), lam], [mu, 0, 0, 0]])
        n_lobe += nl
        max_lobes = max(max_lobes, nl)
        # header (0,0,0,0), (0,0,0,n_asg) after the SG lobes, then the ASG lobes (asg.h):
        # (z, λ), (c, μ, φ, 0), the sharp axis x at angle φ about z (core.asg.x_angle)
        na = len(m.asg_lambda) if np.any(np.asarray(m.ks) > 0) else 0
        lobes.append([[0, 0, 0, 0], [0, 0, 0, na]])
        for z, x, lam, mu, c in zip(m.asg_z[:na], m.asg_x[:na], m.asg_lambda[:na],
                                    m.asg_mu[:na], m.asg_amp[:na]):
            z = np.asarray(z, float) / np.linalg.norm(z)
            lobes.append([[*z, lam], [c, mu, x_angle(z, x), 0]])
        n_lobe += 1 + na
        r[STAB] = n_tab
        st = np.ones(90, np.float32)
        st[:len(m.shadow_table)] = np.asarray(m.shadow_table, np.float32)[:90]
        tables.append(st)
        n_tab += 90
        if m.ndf_table is not None:
            ndf_info[i] = (n_tab, *m.ndf_table.shape, 1)
            tables.append(m.ndf_table.reshape(-1).astype(np.float32))
            n_tab += m.ndf_table.size
        r[GMM] = -1
        if m.gmm is not None:
            (nt, npp, kl, tmax, flags), rows = _gmm_block(m.gmm)
            r[GMM], r[GMM_NT], r[GMM_NP], r[GMM_K] = n_gmm, nt, npp, kl
            r[GMM_TMAX], r[GMM_FLAGS] = tmax, flags
            gmm.append(rows)
            n_gmm += len(rows)
            max_k = max(max_k, kl)
        r[KDTEX], r[KSTEX] = m.kd_texture, m.ks_texture
        r[BCTEX] = r[MRTEX] = r[SVLOB] = r[ETAB] = r[ETGRID] = r[ANTEX] = -1
        r[GMR] = -1
        g = m.gltf
        blocks = (_gmm_rough_blocks(m.gmm_rough, m.gmm) if m.gmm_rough is not None
                  and g is not None and g.anisotropy == 0.0
                  and (g.base_texture >= 0 or g.metal_rough_texture >= 0) else None)
        if blocks is not None:
            r[GMR_N], r[GMR_A0], r[GMR_A1], rows = blocks
            r[GMR] = n_gmm
            gmm.append(rows)
            n_gmm += len(rows)
        r[WARPN] = float(m.exact_warp)
        r[EMIT:EMIT + 3] = np.asarray(m.emission, float)
        r[EMTEX] = m.emission_texture
        r[AROT] = m.frame_rotation
        for slot, tab in ((ETAB, m.energy), (ETGRID, m.energy_grid)):
            if tab is not None:
                pad = -n_tab % 4               # the kernels read these rows as float4
                tables.append(np.zeros(pad, np.float32))
                n_tab += pad
                r[slot] = n_tab
                tables.append(np.asarray(tab, np.float32).reshape(-1))
                n_tab += tab.size
        g = m.gltf
        if g is not None:
            r[BASE:BASE + 3] = g.base_color
            r[METAL], r[ROUGH], r[ANISO] = g.metallic, g.roughness, g.anisotropy
            r[BCTEX], r[MRTEX], r[SVLIN] = g.base_texture, g.metal_rough_texture, g.linear
            r[ANTEX] = g.anisotropy_texture
            grid = m.rough_grid
            if g.metal_rough_texture >= 0 and grid is not None and g.anisotropy == 0.0:
                # the roughness grid's lobe sets, each laid out as a material's (its SG
                # lobes, then the ASG header row with no ASG lobes), entry after entry
                ne, nk = grid.sharpness.shape
                r[SVLOB], r[SVN], r[SVSTEP] = n_lobe, ne, nk + 1
                r[SVA0], r[SVA1] = grid.alpha[0], grid.alpha[-1]
                for lam_e, mu_e in zip(grid.sharpness, grid.amplitude):
                    for lam, mu in zip(lam_e, mu_e):
                        lobes.append([[0, 0, 1, lam], [mu, 0, 0, 0]])
                    lobes.append([[0, 0, 0, 0], [0, 0, 0, 0]])
                n_lobe += ne * (nk + 1)
                max_lobes = max(max_lobes, nk)
    return MaterialTable(
        names=[m.name for m in materials], records=recs,
        lobes=np.asarray(lobes, np.float32).reshape(-1, 2, 4) if lobes else np.zeros((1, 2, 4),
                                                                                  np.float32),
        tables=np.concatenate(tables) if tables else np.ones(90, np.float32),
        gmm=np.concatenate(gmm) if gmm else np.zeros((1, 4), np.float32),
        ndf_info=ndf_info, max_lobes=max_lobes, max_gmm_lobes=max_k)
