"""Per-view vMF mixtures of ρ(i, o_j)(n·i) (Töral19 §IV eq 3–5), independent or coherent
across neighbouring views (Han07 eq 23 alignment prior; Töral19's stated future work)."""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass, field

import numpy as np

from sgpipe.brdf.base import LUMINANCE
from sgpipe.core.quadrature import lobe_quadrature
from sgpipe.core.rotation import rotation_between
from sgpipe.core.vmf import vmf_pdf
from sgpipe.fit.em import KAPPA_MAX, init_sort_split, spherical_em, spherical_em_batch


@dataclass
class ViewGMM:
    """Arrays of docs/ARTIFACTS.md `view_gmm.npz` (float64 here; the stage writes float32)."""

    view_theta: np.ndarray
    view_phi: np.ndarray
    view_dirs: np.ndarray
    alpha: np.ndarray        # (J,K,3)
    kappa: np.ndarray        # (J,K)
    mu: np.ndarray           # (J,K,3)
    albedo: np.ndarray       # (J,3)
    includes_diffuse: bool
    coherent: bool
    rel_l2: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def n_lobes(self) -> int:
        return self.alpha.shape[1]

    def mu_angles(self):
        """(mu_theta, mu_phi) with mu_phi relative to the view's mirror azimuth φ_j + π."""
        th = np.arccos(np.clip(self.mu[..., 2], -1.0, 1.0))
        phi_abs = np.arctan2(self.mu[..., 1], self.mu[..., 0])
        ref = np.repeat(self.view_phi[None, :], len(self.view_theta), 0).ravel() + np.pi
        rel = np.angle(np.exp(1j * (phi_abs - ref[:, None])))
        rel = np.where(rel <= -np.pi, np.pi, rel)
        return th, rel

    def arrays(self) -> dict:
        """The fit under the `view_gmm.npz` names, unrounded (the artifact writer stores float32
        and makes the texture and its preview from these values)."""
        th, ph = self.mu_angles()
        return {"view_theta": self.view_theta, "view_phi": self.view_phi,
                "view_dirs": self.view_dirs, "alpha": self.alpha, "kappa": self.kappa,
                "mu": self.mu, "mu_theta": th, "mu_phi": ph, "albedo": self.albedo,
                "rel_l2": self.rel_l2, "includes_diffuse": self.includes_diffuse,
                "coherent": self.coherent}


def _thread_map(fn, items):
    """Ordered map over threads (numpy releases the GIL in the big array operations)."""
    import numba
    items = list(items)
    n = max(1, min(numba.get_num_threads(), len(items)))
    if n == 1:
        return [fn(it) for it in items]
    ex = ThreadPoolExecutor(max_workers=n)
    try:
        return list(ex.map(fn, items))
    finally:       # on Ctrl-C drop the queued items: only the running ones are waited for
        ex.shutdown(wait=True, cancel_futures=True)


def view_grid(n_theta: int, n_phi: int, theta_max: float):
    """θ_t = θ_max t/(Nθ−1), φ_p = 2πp/Nφ; directions (J,3) with j = t·Nφ + p."""
    theta = theta_max * np.arange(n_theta) / max(n_theta - 1, 1)
    phi = 2.0 * np.pi * np.arange(n_phi) / n_phi
    t, p = np.meshgrid(theta, phi, indexing="ij")
    dirs = np.stack([np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t)], -1)
    return theta, phi, dirs.reshape(-1, 3)


def mirror(o):
    """Mirror direction about the normal (−o_x, −o_y, o_z)."""
    return np.asarray(o, float) * np.array([-1.0, -1.0, 1.0])


def slice_values(brdf, o, i, include_diffuse: bool):
    """ρ(o, i)(n·i) (or its specular part) RGB (..., 3)."""
    f = brdf.eval(o, i) if include_diffuse else brdf.specular(o, i)
    return f * np.maximum(np.asarray(i)[..., 2], 0.0)[..., None]


def draw_samples(brdf, dirs, n_samples: int, seed: int, include_diffuse: bool):
    """Importance samples of each slice: x (J,M,3), luminance weights f_Y/pdf (J,M), and the
    per-sample colour ratios f_c/f_Y (J,M,3) used as Han07 eq 22 feature vectors.

    The (u1, u2) are scrambled Sobol points (one independent scramble per view): their even
    spread removes most of the sampling noise that plain random samples leave in EM fits."""
    n_j = dirs.shape[0]
    # about 2^16 samples per thread task: Ctrl-C waits only for the tasks already running
    step = max(1, min(8, 65536 // max(n_samples, 1)))
    chunks = [(s, min(s + step, n_j)) for s in range(0, n_j, step)]
    parts = _thread_map(lambda c: _draw_chunk(brdf, dirs[c[0]:c[1]], n_samples, seed, c[0],
                                              include_diffuse), chunks)
    x, w, y = (np.concatenate([p[k] for p in parts]) for k in range(3))
    return np.ascontiguousarray(x), w, y


def _draw_chunk(brdf, dirs, n_samples, seed, first, include_diffuse):
    n_j = dirs.shape[0]
    u = sobol_points(n_j, n_samples, seed, first)
    lobe = "all" if include_diffuse else "specular"
    o = np.broadcast_to(dirs[:, None, :], (n_j, n_samples, 3))
    x, pdf = brdf.sample(o, u[0], u[1], lobe=lobe)
    f = slice_values(brdf, o, x, include_diffuse)
    fy = f @ LUMINANCE
    ok = (pdf > 0) & (fy > 0)
    w = np.where(ok, fy / np.where(ok, pdf, 1.0), 0.0)
    y = np.where(ok[..., None], f / np.where(ok, fy, 1.0)[..., None], 1.0)
    return x, w, y


def sobol_points(n_sets: int, n: int, seed: int, first: int = 0) -> np.ndarray:
    """(2, n_sets, n) scrambled Sobol points in [0,1)²; set j is scrambled by (seed, first + j)."""
    import warnings

    from scipy.stats import qmc
    out = np.empty((n_sets, n, 2))
    for j in range(n_sets):
        eng = qmc.Sobol(2, scramble=True, seed=np.random.default_rng([seed, first + j]))
        with warnings.catch_warnings():          # non-powers of 2 lose balance, still fine
            warnings.simplefilter("ignore")
            out[j] = eng.random(n)
    return np.moveaxis(out, -1, 0)


def slice_grid(brdf, o, kappa_hint: float = 0.0):
    """A dense quadrature rule over S² graded towards the mirror direction of o."""
    width = brdf.ndf_model.width() if brdf.ndf_model is not None else 1.0
    lam = max(0.5 / max(width, 1e-3) ** 2, float(kappa_hint), 1.0)
    return lobe_quadrature(mirror(o), lam, n_per_panel=16, n_phi=128)


def mixture_values(alpha, mu, kappa, x):
    """Σ_k alpha_k(…,C) vMF(x; mu_k, kappa_k) at x (N,3) -> (N, C)."""
    pdf = vmf_pdf(np.asarray(x)[:, None, :], mu[None], kappa[None])   # (N,K)
    return pdf @ alpha


def slice_error(brdf, o, alpha, mu, kappa, include_diffuse: bool):
    """Relative L2 (luminance) of a mixture vs ρ(o,i)(n·i) over S², and the RGB integral."""
    x, w = slice_grid(brdf, o, float(np.max(kappa, initial=0.0)))
    f = slice_values(brdf, o, x, include_diffuse)
    g = mixture_values(alpha, mu, kappa, x)
    fy, gy = f @ LUMINANCE, g @ LUMINANCE
    den = float(np.sum(w * fy * fy))
    err = float(np.sqrt(np.sum(w * (fy - gy) ** 2) / den)) if den > 0 else 0.0
    return err


def slice_integral(brdf, o, include_diffuse: bool):
    """∫ ρ_c(o,i)(n·i) di (RGB) by the dense graded quadrature."""
    x, w = slice_grid(brdf, o)
    return w @ slice_values(brdf, o, x, include_diffuse)


def _amplitudes(weight, colour, integral):
    """alpha_kc = π_k y_kc (eq 22 colours) rescaled so Σ_k alpha_kc = ∫ρ_c cos (Töral19)."""
    a = weight[:, None] * colour
    s = a.sum(axis=0)
    return a * np.where(s > 0, integral / np.where(s > 0, s, 1.0), 0.0)


def _coherent_fits(x, w, y, dirs, n_theta, n_phi, n_lobes, align, max_iter, tol):
    """Fit views in scanline order; each starts from its (rotated) neighbour and is pulled
    towards the neighbours' lobes by Han07 eq 23 (strength `align`)."""
    n_j = dirs.shape[0]
    alpha = np.zeros((n_j, n_lobes))
    mu = np.zeros((n_j, n_lobes, 3))
    kappa = np.ones((n_j, n_lobes))
    col = np.ones((n_j, n_lobes, 3))
    for t in range(n_theta):
        for p in range(n_phi):
            j = t * n_phi + p
            nbs = [q for q in ((t - 1) * n_phi + p if t > 0 else -1,
                               j - 1 if p > 0 else -1) if q >= 0]
            rotated = []
            for q in nbs:
                r = rotation_between(mirror(dirs[q]), mirror(dirs[j]))
                rotated.append((alpha[q], mu[q] @ r.T, kappa[q]))
            if rotated and rotated[0][0].sum() > 0:
                init = (np.maximum(rotated[0][0], 1e-3), rotated[0][1], rotated[0][2])
            else:
                init = init_sort_split(x[j], w[j], n_lobes)
            m = spherical_em(x[j], w[j], n_lobes, init=init, features=y[j],
                             neighbors=[(a, m_) for a, m_, _ in rotated], align=align,
                             max_iter=max_iter, tol=tol)
            alpha[j], mu[j], kappa[j], col[j] = m.alpha, m.mu, m.kappa, m.features
    return alpha, mu, kappa, col


def fit_view_gmm(brdf, *, n_theta: int = 16, n_phi: int = 1, theta_max: float = np.radians(85),
                 n_lobes: int = 8, n_samples: int = 4096, max_iter: int = 100,
                 tol: float = 1e-5, coherent: bool = False, align: float = 1.0, seed: int = 0,
                 include_diffuse: bool = False, errors: bool = True,
                 anisotropic_lobes: int = 0) -> ViewGMM:
    """Töral19 §IV: for views o_j draw M importance samples of ρ(i,o_j)(n·i), fit K vMF
    lobes by spherical EM, scale amplitudes to the slice integral.

    anisotropic_lobes > 0 replaces n_lobes for anisotropic BRDFs: an r:1 lobe needs a chain of
    about r/2 isotropic vMFs along its long axis (fewer leave beads or blur its narrow side)."""
    if anisotropic_lobes > 0 and not getattr(brdf, "isotropic", True):
        n_lobes = int(anisotropic_lobes)
    theta, phi, dirs = view_grid(n_theta, n_phi, theta_max)
    x, w, y = draw_samples(brdf, dirs, n_samples, seed, include_diffuse)
    if coherent:
        alpha, mu, kappa, col = _coherent_fits(x, w, y, dirs, n_theta, n_phi, n_lobes, align,
                                               max_iter, tol)
    else:
        m = spherical_em_batch(x, w, n_lobes, features=y, max_iter=max_iter, tol=tol)
        alpha, mu, kappa, col = m.alpha, m.mu, m.kappa, m.features
    integ = np.stack(_thread_map(lambda o: slice_integral(brdf, o, include_diffuse), dirs))
    amp = np.stack([_amplitudes(alpha[j], col[j], integ[j]) for j in range(len(dirs))])
    if not coherent:       # independent fits: lobes by decreasing luminance amplitude
        order = np.argsort(-(amp @ LUMINANCE), axis=1, kind="stable")
        amp = np.take_along_axis(amp, order[..., None], 1)
        mu = np.take_along_axis(mu, order[..., None], 1)
        kappa = np.take_along_axis(kappa, order, 1)
    gmm = ViewGMM(theta, phi, dirs, amp, np.minimum(kappa, KAPPA_MAX), mu, integ,
                  include_diffuse, coherent)
    if errors:
        gmm.rel_l2 = np.array(_thread_map(
            lambda j: slice_error(brdf, dirs[j], amp[j], mu[j], kappa[j], include_diffuse),
            range(len(dirs))))
    return gmm


def warp_lobes(o_fit, o, mu, kappa):
    """Carry lobes (mu (K,3), kappa (K,)) fitted at view o_fit to view o with each lobe's half
    vector h = (μ + o_fit)/‖·‖ held fixed: μ' = 2(o·h)h − o, κ' = κ (o_fit·h)/(o·h) (the
    reflection Jacobian dω_i = 4(o·h) dω_h, ratio bounded by 4). Mirror of gmm_shade.cl
    warp_half: the NDF stays put in the tangent frame as the view moves."""
    o_fit, o = np.asarray(o_fit, float), np.asarray(o, float)
    mu = np.asarray(mu, float)
    kappa = np.asarray(kappa, float)
    h = mu + o_fit
    ln = np.linalg.norm(h, axis=-1, keepdims=True)
    ok = ln[..., 0] > 1e-4
    h = h / np.where(ln > 1e-4, ln, 1.0)
    og_h, op_h = h @ o_fit, h @ o
    ok &= op_h > 1e-3
    mu2 = np.where(ok[..., None], 2.0 * op_h[..., None] * h - o, mu)
    k2 = np.where(ok, kappa * np.minimum(og_h / np.where(ok, op_h, 1.0), 4.0), kappa)
    return mu2, k2


def nearest_view_errors(brdf, gmm: ViewGMM, views, carry: str = "warp"):
    """Relative L2 of the nearest grid view's mixture at arbitrary views (V,3), its lobes
    carried by `carry`: "warp" (warp_lobes, the renderer's default), "rotate" (rigid rotation
    of the mirror directions), "none" (Töral19)."""
    errs = []
    dirs = gmm.view_dirs
    for o in np.asarray(views, float):
        if len(gmm.view_phi) == 1:     # isotropic grid: views at φ = 0, turned to o's azimuth
            j = int(np.argmin(np.abs(gmm.view_theta - np.arccos(np.clip(o[2], -1.0, 1.0)))))
            a = np.arctan2(o[1], o[0])
            rz = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0],
                           [0.0, 0.0, 1.0]])
            og, mu = rz @ dirs[j], gmm.mu[j] @ rz.T
        else:
            j = int(np.argmax(dirs @ o))
            og, mu = dirs[j], gmm.mu[j]
        kappa = gmm.kappa[j]
        if carry == "warp":
            mu, kappa = warp_lobes(og, o, mu, kappa)
        elif carry == "rotate":
            mu = mu @ rotation_between(mirror(og), mirror(o)).T
        errs.append(slice_error(brdf, o, gmm.alpha[j], mu, kappa, gmm.includes_diffuse))
    return np.array(errs)


def interpolation_errors(brdf, gmm: ViewGMM):
    """Relative L2 at held-out views halfway in θ between grid views, using lobe-wise
    interpolation (alpha, kappa lerp; mu nlerp) -> (held-out θ (H,), errors (H,))."""
    n_t, n_p = len(gmm.view_theta), len(gmm.view_phi)
    th, errs = [], []
    for t in range(n_t - 1):
        for p in range(n_p):
            a, b = t * n_p + p, (t + 1) * n_p + p
            tm = 0.5 * (gmm.view_theta[t] + gmm.view_theta[t + 1])
            ph = gmm.view_phi[p]
            o = np.array([np.sin(tm) * np.cos(ph), np.sin(tm) * np.sin(ph), np.cos(tm)])
            alpha = 0.5 * (gmm.alpha[a] + gmm.alpha[b])
            kappa = 0.5 * (gmm.kappa[a] + gmm.kappa[b])
            mu = gmm.mu[a] + gmm.mu[b]
            mu /= np.maximum(np.linalg.norm(mu, axis=-1, keepdims=True), 1e-12)
            th.append(tm)
            errs.append(slice_error(brdf, o, alpha, mu, kappa, gmm.includes_diffuse))
    return np.array(th), np.array(errs)


def lobe_curve(brdf, thetas, max_lobes: int, *, n_samples: int = 4096, seed: int = 0,
               include_diffuse: bool = False, max_iter: int = 100, tol: float = 1e-5):
    """Relative L2 error of independent K-lobe fits, K = 1…max_lobes, at views of elevation
    `thetas` (φ = 0), all from the same samples -> (len(thetas), max_lobes)."""
    thetas = np.asarray(thetas, float)
    dirs = np.stack([np.sin(thetas), np.zeros_like(thetas), np.cos(thetas)], -1)
    x, w, y = draw_samples(brdf, dirs, n_samples, seed, include_diffuse)
    out = np.zeros((len(thetas), max_lobes))
    for j, o in enumerate(dirs):
        integ = slice_integral(brdf, o, include_diffuse)
        for k in range(1, max_lobes + 1):
            m = spherical_em(x[j], w[j], k, features=y[j], max_iter=max_iter, tol=tol)
            amp = _amplitudes(m.alpha, m.features, integ)
            out[j, k - 1] = slice_error(brdf, o, amp, m.mu, m.kappa, include_diffuse)
    return out


def slice_images(brdf, gmm: ViewGMM, thetas, res: int = 96):
    """(function, fit) hemisphere images (luminance) at the grid views nearest to `thetas`."""
    from sgpipe.fit.plot import hemisphere_image
    rows = []
    n_p = len(gmm.view_phi)
    for th in thetas:
        t = int(np.argmin(np.abs(gmm.view_theta - th)))
        j = t * n_p
        o = gmm.view_dirs[j]
        f = hemisphere_image(lambda d: slice_values(brdf, o, d, gmm.includes_diffuse) @ LUMINANCE,
                             res)
        g = hemisphere_image(lambda d: mixture_values(gmm.alpha[j], gmm.mu[j], gmm.kappa[j], d)
                             @ LUMINANCE, res)
        rows.append((f, g))
    return rows
