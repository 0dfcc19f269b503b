"""Wang09 §4.2 eq 13–14: tabulated microfacet model ρ = kd/π + ks F S(θ_i)S(θ_o)D(θ_h)/(π cos cos)
extracted from a MERL table; S compressed to 8-D by PCA; the measured BRDF wrapper `MerlBRDF`."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from sgpipe.brdf.base import LUMINANCE, BRDF
from sgpipe.brdf.fresnel import Fresnel, fresnel_dielectric
from sgpipe.brdf.merl import RES_TH, cell_centres, from_half_diff, merl_lookup, read_merl
from sgpipe.brdf.ndf import TabulatedNDF
from sgpipe.brdf.shadowing import SHADOW_THETA, Shadowing, smith_g1_beckmann, smith_g1_ggx

#: θ_h bin centres of MERL's non-linear θ_h axis (the tabulated D lives there).
NDF_THETA = ((np.arange(RES_TH) + 0.5) / RES_TH) ** 2 * (np.pi / 2)


@dataclass
class TabulatedFit:
    """Result of `fit_tabulated` (arrays as in docs/ARTIFACTS.md `tabulated.npz`)."""

    ndf: np.ndarray
    shadow: np.ndarray
    shadow_raw: np.ndarray
    pca_mean: np.ndarray
    pca_basis: np.ndarray
    pca_coeffs: np.ndarray
    kd: np.ndarray
    ks: np.ndarray
    eta: float
    rel_err: float

    def arrays(self) -> dict:
        return {"ndf_theta_h": NDF_THETA.astype(np.float32),
                "ndf_table": self.ndf.astype(np.float32),
                "shadow_table": self.shadow.astype(np.float32),
                "shadow_pca_mean": self.pca_mean.astype(np.float32),
                "shadow_pca_basis": self.pca_basis.astype(np.float32),
                "shadow_pca_coeffs": self.pca_coeffs.astype(np.float32),
                "eta": np.float32(self.eta)}


def shadow_pca(shadow, n_components: int = 8):
    """Wang09 §4.2: compress a 90-D shadowing vector to n coefficients with a PCA basis built
    from Smith GGX/Beckmann G1 curves (α ∈ [0.02, 1]) plus the vector itself.
    Returns (mean (90,), basis (n, 90), coeffs (n,), reconstruction (90,))."""
    lib = np.vstack(_g1_library(np.geomspace(0.02, 1.0, 24)) + [np.asarray(shadow, float)])
    mean = lib.mean(axis=0)
    _, _, vt = np.linalg.svd(lib - mean, full_matrices=False)
    basis = vt[:n_components]
    coeffs = basis @ (shadow - mean)
    return mean, basis, coeffs, mean + coeffs @ basis


def _g1_library(alphas) -> list:
    """Smith G1 of GGX and Beckmann at each α on the 90 SHADOW_THETA bins."""
    v = np.stack([np.sin(SHADOW_THETA), np.zeros(90), np.cos(SHADOW_THETA)], -1)
    return [g(v, a, a) for a in alphas for g in (smith_g1_ggx, smith_g1_beckmann)]


def shadow_tail(shadow, max_theta_deg: float, band_deg: float = 20.0) -> np.ndarray:
    """S beyond `max_theta_deg`, where no data constrain it, continued by the Smith G1 curve
    (GGX or Beckmann, α from 0.01 to 2) whose shape best fits the last `band_deg` of the
    constrained bins, scaled to meet S at the last one: a microfacet surface's S vanishes at
    grazing, which the least squares' smooth extrapolation does not know."""
    shadow = np.asarray(shadow, float)
    deg = np.degrees(SHADOW_THETA)
    fit = deg < max_theta_deg
    if fit.all():
        return shadow.copy()
    band = fit & (deg >= max_theta_deg - band_deg)
    lib = np.vstack(_g1_library(np.geomspace(0.01, 2.0, 96)))
    scale = lib[:, band] @ shadow[band] / np.sum(lib[:, band] ** 2, axis=1)
    err = np.sum((scale[:, None] * lib[:, band] - shadow[band]) ** 2, axis=1)
    best = lib[int(np.argmin(err))]
    last = int(np.flatnonzero(fit)[-1])
    out = shadow.copy()
    out[~fit] = best[~fit] * shadow[last] / best[last]
    return out


def _second_diff(n):
    d = np.zeros((n - 2, n))
    for k in range(n - 2):
        d[k, k:k + 3] = (1.0, -2.0, 1.0)
    return d.T @ d


def _log_ls(t, w, hb, ib, ob, smooth):
    """Weighted least squares for log D[hb] + log S[ib] + log S[ob] ≈ t with log S[0] = 0."""
    n = 2 * RES_TH
    cols = (hb, RES_TH + ib, RES_TH + ob)
    ata = np.zeros(n * n)
    atb = np.zeros(n)
    for a in cols:
        atb += np.bincount(a, weights=w * t, minlength=n)
        for b in cols:
            ata += np.bincount(a * n + b, weights=w, minlength=n * n)
    ata = ata.reshape(n, n)
    reg = smooth * float(w.sum()) / n
    ata[:RES_TH, :RES_TH] += reg * _second_diff(RES_TH)
    ata[RES_TH:, RES_TH:] += reg * _second_diff(RES_TH)
    ata[RES_TH, RES_TH] += 1e6 * float(w.sum())       # pins log S(0) = 0
    ata += 1e-9 * float(w.sum()) * np.eye(n)
    x = np.linalg.solve(ata, atb)
    return x[:RES_TH], x[RES_TH:]


def fit_tabulated(table, *, eta: float = 1.33, iterations: int = 4, phi_stride: int = 3,
                  max_theta_deg: float = 80.0) -> TabulatedFit:
    """Extract D (MERL θ_h bins), isotropic S (90 uniform bins) and kd, ks from a MERL table by
    alternating a log-domain least squares for D and S with a linear solve for kd, ks."""
    th, td, pd = (a[:, :, ::phi_stride] for a in cell_centres())
    rho = table[:, :, :, ::phi_stride]
    o, i = from_half_diff(th, td, pd)
    ci, co = i[..., 2], o[..., 2]
    cmin = np.cos(np.radians(max_theta_deg))
    valid = (ci > cmin) & (co > cmin) & np.all(rho >= 0, axis=0)
    hb = np.broadcast_to(np.arange(RES_TH)[:, None, None], th.shape)[valid]
    rho = np.moveaxis(rho, 0, -1)[valid]
    ci, co, td = ci[valid], co[valid], td[valid]
    ib = np.minimum((np.arccos(ci) / (np.pi / 2) * 90).astype(np.int64), 89)
    ob = np.minimum((np.arccos(co) / (np.pi / 2) * 90).astype(np.int64), 89)
    fr = fresnel_dielectric(np.cos(td), eta)[..., 0]
    y = rho @ LUMINANCE
    far = np.degrees(th[..., 0, 0])[hb] > 45.0
    kd = np.percentile(rho[far], 5, axis=0) * np.pi if far.any() else np.zeros(3)
    ks = np.ones(3)
    logd = logs = None
    for _ in range(iterations):
        s = y - float(kd @ LUMINANCE) / np.pi
        m = (s > 1e-4 * s.max()) & (s > 0.05 * float(kd @ LUMINANCE) / np.pi)
        t = np.log(s[m] * np.pi * ci[m] * co[m] / fr[m])
        w = s[m] / s[m].max() + 1e-3
        logd, logs = _log_ls(t, w, hb[m], ib[m], ob[m], smooth=1e-4)
        d = np.exp(logd - logd[0])
        sh = np.exp(logs)
        g = fr * sh[ib] * sh[ob] * d[hb] / (np.pi * ci * co)
        wt = 1.0 / (y + 1e-3 * y.max()) ** 2
        a = np.stack([np.full_like(g, 1.0 / np.pi), g], -1)
        ata = a.T @ (a * wt[:, None])
        for c in range(3):
            kd[c], ks[c] = np.maximum(np.linalg.solve(ata, a.T @ (wt * rho[:, c])), 0.0)
    sh = shadow_tail(sh, max_theta_deg)
    mean, basis, coeffs, recon = shadow_pca(sh)
    recon = np.maximum(recon, 0.0)
    pred = kd / np.pi + ks * (fr * recon[ib] * recon[ob] * d[hb] / (np.pi * ci * co))[:, None]
    err = float(np.sqrt(np.sum(((pred - rho) @ LUMINANCE) ** 2) / np.sum(y ** 2)))
    return TabulatedFit(ndf=d, shadow=recon, shadow_raw=sh, pca_mean=mean, pca_basis=basis,
                        pca_coeffs=coeffs, kd=kd, ks=ks, eta=float(eta), rel_err=err)


def tabulated_brdf(fit: TabulatedFit, name: str = "tabulated") -> BRDF:
    """The eq 13 model of a `TabulatedFit` as a BRDF (dielectric Fresnel η, tabulated S and D)."""
    eta = np.full(3, fit.eta)
    return BRDF(name, kd=fit.kd, ks=fit.ks, ndf=TabulatedNDF(NDF_THETA, fit.ndf),
                fresnel=Fresnel("dielectric", eta=eta),
                shadowing=Shadowing("tabulated", table=fit.shadow), g_scale=1.0)


class MerlBRDF(BRDF):
    """Measured MERL BRDF: `eval` looks the table up; sampling, pdf, NDF and M_o(i) come from
    the fitted tabulated microfacet model (`self.fit`)."""

    def __init__(self, table, *, eta: float = 1.33, source: str | None = None):
        self.table = np.asarray(table, float)
        self.fit = fit_tabulated(self.table, eta=eta)
        model = tabulated_brdf(self.fit)
        super().__init__("tabulated", kd=model.kd, ks=model.ks, ndf=model.ndf_model,
                         fresnel=model.fresnel, shadowing=model.shadowing, g_scale=1.0,
                         params={"merl_file": source, "eta": eta})
        self.model = model

    def eval(self, o, i):
        return merl_lookup(self.table, o, i)

    def specular(self, o, i):
        return np.maximum(self.eval(o, i) - self.diffuse(o, i), 0.0)


def load_merl(path, *, eta: float = 1.33, key: str | None = None) -> MerlBRDF:
    """Read a MERL file (BadInput on a bad file) and fit its tabulated microfacet model."""
    return MerlBRDF(read_merl(path, key=key), eta=eta, source=str(path))
