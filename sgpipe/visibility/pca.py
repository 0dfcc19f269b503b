"""PCA of per-vertex SSDF images (Wang09 eq 24) by a streaming randomized SVD.

The data matrix X (V vertices × D texels) lives in a float32 memmap on disk; every pass reads
it in row blocks, so memory is O(block·D + D·l), never O(V·D). With l = k + oversampling ≥
rank(X − mean) the result is the exact PCA (e.g. all terms of a small mesh).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class SsdfPCA:
    """mean (D,), basis (k, D) orthonormal rows, coeffs (V, k), per-term variance, and the
    exact residual energy Σ‖x − mean − Σ_{j<m} c_j e_j‖² for m = 0..k (Wang09 Fig 9)."""

    mean: np.ndarray
    basis: np.ndarray
    coeffs: np.ndarray
    explained_variance: np.ndarray
    residual_energy: np.ndarray

    def reconstruct(self, rows: np.ndarray | slice = slice(None), terms: int | None = None):
        """mean + coeffs[rows, :terms] @ basis[:terms] (float64)."""
        m = self.basis.shape[0] if terms is None else int(terms)
        return self.mean + self.coeffs[rows, :m].astype(np.float64) @ self.basis[:m]


def _blocks(n: int, block: int):
    for s in range(0, n, block):
        yield s, min(n, s + block)


def _orth(a: np.ndarray) -> np.ndarray:
    q, _ = np.linalg.qr(a)
    return q


def streaming_pca(X: np.ndarray, k: int, *, oversample: int = 10, power_iterations: int = 3,
                  seed: int = 0, block: int = 1024) -> SsdfPCA:
    """Top-k PCA of the rows of X (an array or memmap (V, D)) in a fixed number of passes.

    Halko–Martinsson–Tropp randomized range finder on the centred matrix, with power
    iterations; centring is applied implicitly (X − 1 mᵀ) so X is never copied."""
    n, d = X.shape
    # float32 data (the SSDF memmap) runs its matrix products in float32 (2x faster BLAS);
    # accumulators and the final SVD stay float64
    dt = np.float32 if np.dtype(X.dtype) == np.float32 else np.float64
    k = int(min(k, n, d))
    l_ = int(min(k + oversample, n, d))
    rng = np.random.default_rng(seed)
    omega = rng.standard_normal((d, l_))
    omega_t = omega.astype(dt)
    # pass 1: column sums, total energy and X Ω together
    total = np.zeros(d)
    energy = 0.0
    Y = np.empty((n, l_))
    for s, e in _blocks(n, block):
        xb = np.asarray(X[s:e], dtype=dt)
        total += xb.sum(axis=0, dtype=np.float64)
        energy += float(np.einsum("ij,ij->", xb, xb, dtype=np.float64))
        Y[s:e] = xb @ omega_t
    mean = total / n
    energy_c = max(0.0, energy - n * float(mean @ mean))
    Y -= (mean @ omega)[None, :]
    Q = _orth(Y)
    for _ in range(power_iterations):
        Z = np.zeros((d, l_))
        Qt = Q.astype(dt)
        for s, e in _blocks(n, block):
            Z += np.asarray(X[s:e], dtype=dt).T @ Qt[s:e]
        Z -= np.outer(mean, Q.sum(axis=0))
        Z = _orth(Z)
        Zt = Z.astype(dt)
        for s, e in _blocks(n, block):
            Y[s:e] = np.asarray(X[s:e], dtype=dt) @ Zt
        Y -= (mean @ Z)[None, :]
        Q = _orth(Y)
    B = np.zeros((l_, d))
    for s, e in _blocks(n, block):
        B += Q[s:e].T @ np.asarray(X[s:e], dtype=np.float64)   # final pass in float64
    B -= np.outer(Q.sum(axis=0), mean)
    _, sv, vt = np.linalg.svd(B, full_matrices=False)
    basis = vt[:k]
    # deterministic sign: the largest-magnitude texel of each eigen-image is positive
    idx = np.argmax(np.abs(basis), axis=1)
    basis *= np.sign(basis[np.arange(k), idx])[:, None]
    coeffs = np.empty((n, k))
    for s, e in _blocks(n, block):
        coeffs[s:e] = (np.asarray(X[s:e], dtype=np.float64) - mean) @ basis.T
    captured = np.concatenate([[0.0], np.cumsum(np.einsum("ij,ij->j", coeffs, coeffs))])
    residual = np.maximum(0.0, energy_c - captured)
    return SsdfPCA(mean=mean, basis=basis, coeffs=coeffs,
                   explained_variance=sv[:k] ** 2 / max(n, 1), residual_energy=residual)
