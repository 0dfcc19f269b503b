"""Accuracy report of the visibility representation: SSDF products vs ray tracing (Wang09
Fig 7), PCA error vs number of terms (Fig 9), and preview panels."""

from __future__ import annotations

import numpy as np

from sgpipe.core.fh import fh_hemisphere
from sgpipe.visibility.decode import decode_ssdf_image, decode_ssdf_local
from sgpipe.visibility.products import raytraced_sg_visibility, sg_visibility_integral
from sgpipe.visibility.trace import occluded


def pick_vertices(visible_fraction: np.ndarray, count: int, seed: int) -> np.ndarray:
    """Deterministic sample of vertices, preferring partly occluded ones (5–95 % visible)."""
    n = len(visible_fraction)
    if count <= 0 or n == 0:
        return np.zeros(0, np.int64)
    rng = np.random.default_rng(seed)
    partial = np.flatnonzero((visible_fraction > 0.05) & (visible_fraction < 0.95))
    pool = partial if len(partial) >= count else np.arange(n)
    return np.sort(rng.choice(pool, size=min(count, len(pool)), replace=False))


def _local_axes(count: int, rng) -> np.ndarray:
    """Lobe axes uniform on the upper hemisphere above 5° elevation (local frame)."""
    z = rng.uniform(np.sin(np.radians(5.0)), 1.0, count)
    phi = rng.uniform(0.0, 2.0 * np.pi, count)
    r = np.sqrt(1.0 - z * z)
    return np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=-1)


def product_accuracy(scene, position, normal, tangent, bitangent, offset, raw_image,
                     coeffs, mean, basis, *, lambdas, directions, samples, max_distance,
                     seed) -> list[dict]:
    """Per (lobe axis, λ): ray-traced ∫G·V vs μ f_h(θ_d, λ) with θ_d from the raw SSDF and
    from its PCA reconstruction (exact f_h; sigmoid f_h with refit and published
    coefficients). Errors are divided by f_h(π/2, λ), the unoccluded-hemisphere integral."""
    rng = np.random.default_rng(seed)
    frame = np.stack([tangent, bitangent, normal])
    origin = np.asarray(position, float) + offset * np.asarray(normal, float)

    def visible(dirs):
        d32 = np.ascontiguousarray(dirs, dtype=np.float32)
        o32 = np.broadcast_to(origin.astype(np.float32), d32.shape).copy()
        return (dirs @ normal > 0.0) & ~occluded(scene, o32, d32)

    rows = []
    axes_local = _local_axes(directions, rng)
    th_pca = decode_ssdf_local(axes_local, coeffs, mean, basis, max_distance=max_distance)
    th_raw = decode_ssdf_image(raw_image, axes_local, max_distance=max_distance)
    for a, loc in enumerate(axes_local):
        p = loc @ frame
        for lam in lambdas:
            truth = raytraced_sg_visibility(visible, p, lam, n=samples,
                                            seed=seed * 1000 + a * 37 + int(lam))
            norm = float(fh_hemisphere(lam))
            rows.append({
                "axis": a, "lambda": float(lam), "theta_d_raw": float(th_raw[a]),
                "theta_d_pca": float(th_pca[a]), "raytraced": truth,
                "err_exact_raw": (float(sg_visibility_integral(th_raw[a], lam)) - truth) / norm,
                "err_exact_pca": (float(sg_visibility_integral(th_pca[a], lam)) - truth) / norm,
                "err_sigmoid_pca": (float(sg_visibility_integral(th_pca[a], lam, fh="sigmoid"))
                                    - truth) / norm,
                "err_sigmoid_published_pca": (float(sg_visibility_integral(
                    th_pca[a], lam, fh="sigmoid_published")) - truth) / norm,
            })
    return rows


def summarize_products(rows: list[dict]) -> dict:
    """Mean |error|, RMS and max |error| per λ and method."""
    out = {}
    for lam in sorted({r["lambda"] for r in rows}):
        sel = [r for r in rows if r["lambda"] == lam]
        entry = {"n": len(sel)}
        for key in ("err_exact_raw", "err_exact_pca", "err_sigmoid_pca",
                    "err_sigmoid_published_pca"):
            e = np.array([r[key] for r in sel])
            entry[key] = {"mean_abs": float(np.mean(np.abs(e))),
                          "rms": float(np.sqrt(np.mean(e * e))),
                          "max_abs": float(np.max(np.abs(e)))}
        out[f"{lam:g}"] = entry
    return out


def pca_error_vs_terms(pca, raw_rows: np.ndarray, sample_rows: np.ndarray) -> dict:
    """Wang09 Fig 9: RMS SSDF error (radians, all vertices, exact from the residual energy)
    and visibility sign disagreement (fraction of texels, on `sample_rows`) per term count."""
    n, d = pca.coeffs.shape[0], pca.mean.size
    k = pca.basis.shape[0]
    terms = sorted({m for m in (0, 1, 2, 4, 8, 12, 16, 24, 32, 48, 64, 96, 128) if m <= k}
                   | {k})
    out = {}
    raw = np.asarray(raw_rows, dtype=np.float64)
    for m in terms:
        rec = pca.reconstruct(sample_rows, m) if len(sample_rows) else np.zeros((0, d))
        flips = float(np.mean((rec > 0) != (raw > 0))) if len(sample_rows) else 0.0
        out[str(m)] = {"rms_rad": float(np.sqrt(pca.residual_energy[m] / (n * d))),
                       "sign_mismatch": flips}
    return out


def signed_preview(img: np.ndarray, scale: float) -> np.ndarray:
    """Diverging colours for a signed image: white at 0, blue > 0, red < 0 (linear, [0,1])."""
    x = np.clip(np.asarray(img, float) / max(scale, 1e-12), -1.0, 1.0)
    pos, neg = np.maximum(x, 0.0), np.maximum(-x, 0.0)
    return np.stack([1.0 - pos, 1.0 - pos - neg, 1.0 - neg], axis=-1)


def vertex_panel(vis_fraction, raw, recon, max_distance) -> np.ndarray:
    """visibility | SSDF | PCA reconstruction | |error| (×4), side by side, linear RGB."""
    res = raw.shape[0]
    gap = np.ones((res, 2, 3))
    err = np.abs(recon - raw) * 4.0 / max_distance
    panels = [np.repeat(vis_fraction[..., None], 3, axis=-1), gap,
              signed_preview(raw, max_distance), gap, signed_preview(recon, max_distance), gap,
              np.repeat(np.clip(1.0 - err, 0.0, 1.0)[..., None], 3, axis=-1)]
    return np.concatenate(panels, axis=1)
