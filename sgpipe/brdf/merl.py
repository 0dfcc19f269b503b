"""MERL `.binary` measured BRDFs (Matusik et al. 2003): reader, writer, half/difference indexing.

File layout: three int32 dimensions (90, 90, 180) = (θ_h, θ_d, φ_d), then 3·90·90·180 float64
values, channel-major (R, G, B), each scaled by 1/1500, 1.15/1500, 1.66/1500. θ_h is indexed
non-linearly (index = ⌊√(θ_h/(π/2))·90⌋), θ_d linearly over [0, π/2), φ_d over [0, π)
(reciprocity). Negative entries mark unmeasured (below-horizon) cells.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from sgpipe.errors import BadInput

RES_TH, RES_TD, RES_PD = 90, 90, 180
SCALES = np.array([1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0])
N_CELLS = RES_TH * RES_TD * RES_PD
FILE_BYTES = 12 + 8 * 3 * N_CELLS


def read_merl(path: str | os.PathLike, *, key: str | None = None) -> np.ndarray:
    """Read a MERL file -> (3, 90, 90, 180) float64 BRDF values (scaled, negative = invalid).

    A missing, truncated, oversized or wrongly dimensioned file is one BadInput line."""
    path = Path(path)
    if not path.is_file():
        raise BadInput("MERL file not found", file=path, key=key)
    size = path.stat().st_size
    if size < 12:
        raise BadInput(f"not a MERL .binary file ({size} bytes, no header)", file=path, key=key)
    with open(path, "rb") as f:
        dims = np.frombuffer(f.read(12), dtype="<i4")
        if tuple(int(d) for d in dims) != (RES_TH, RES_TD, RES_PD):
            raise BadInput(f"MERL header dimensions {tuple(int(d) for d in dims)} != "
                           f"(90, 90, 180)", file=path, key=key)
        if size != FILE_BYTES:
            what = "truncated" if size < FILE_BYTES else "has trailing bytes"
            raise BadInput(f"MERL file {what}: {size} bytes, expected {FILE_BYTES}",
                           file=path, key=key)
        data = np.frombuffer(f.read(), dtype="<f8").astype(float)
    table = data.reshape(3, RES_TH, RES_TD, RES_PD) * SCALES[:, None, None, None]
    if not np.isfinite(table).all():
        raise BadInput("MERL file contains NaN/Inf values", file=path, key=key)
    return table


def write_merl(path: str | os.PathLike, table: np.ndarray) -> Path:
    """Write a (3, 90, 90, 180) table of BRDF values (negative = invalid) as a MERL file."""
    path = Path(path)
    table = np.asarray(table, float)
    if table.shape != (3, RES_TH, RES_TD, RES_PD):
        raise ValueError(f"MERL table must be (3, 90, 90, 180), got {table.shape}")
    raw = table / SCALES[:, None, None, None]
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.name}.tmp{os.getpid()}")
    with open(tmp, "wb") as f:
        f.write(np.array([RES_TH, RES_TD, RES_PD], dtype="<i4").tobytes())
        f.write(raw.astype("<f8").tobytes())
    os.replace(tmp, path)
    return path


def _rot_z(v, a):
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1], v[..., 2]], -1)


def _rot_y(v, a):
    c, s = np.cos(a), np.sin(a)
    return np.stack([c * v[..., 0] + s * v[..., 2], v[..., 1], -s * v[..., 0] + c * v[..., 2]], -1)


def to_half_diff(o, i):
    """(o, i) -> (θ_h, φ_h, θ_d, φ_d) of Rusinkiewicz's half/difference parameterisation."""
    o = np.asarray(o, float)
    i = np.asarray(i, float)
    h = o + i
    h = h / np.maximum(np.linalg.norm(h, axis=-1, keepdims=True), 1e-300)
    th = np.arccos(np.clip(h[..., 2], -1.0, 1.0))
    ph = np.arctan2(h[..., 1], h[..., 0])
    d = _rot_y(_rot_z(i, -ph), -th)
    td = np.arccos(np.clip(d[..., 2], -1.0, 1.0))
    pd = np.arctan2(d[..., 1], d[..., 0])
    return th, ph, td, pd


def from_half_diff(th, td, pd, ph=0.0):
    """(θ_h, θ_d, φ_d[, φ_h]) -> (o, i) unit vectors (inverse of `to_half_diff`)."""
    th, td, pd = (np.asarray(a, float) for a in (th, td, pd))
    d = np.stack([np.sin(td) * np.cos(pd), np.sin(td) * np.sin(pd), np.cos(td)], -1)
    dout = d * np.array([-1.0, -1.0, 1.0])
    i = _rot_z(_rot_y(d, th), ph)
    o = _rot_z(_rot_y(dout, th), ph)
    return o, i


def merl_indices(th, td, pd):
    """Flat-free (θ_h, θ_d, φ_d) cell indices exactly as MERL's BRDFRead.cpp computes them."""
    ih = np.floor(np.sqrt(np.maximum(th, 0.0) / (np.pi / 2)) * RES_TH).astype(np.int64)
    it = np.floor(td / (np.pi / 2) * RES_TD).astype(np.int64)
    pd = np.where(pd < 0.0, pd + np.pi, pd)
    ip = np.floor(pd / np.pi * RES_PD).astype(np.int64)
    return (np.clip(ih, 0, RES_TH - 1), np.clip(it, 0, RES_TD - 1), np.clip(ip, 0, RES_PD - 1))


def cell_centres():
    """θ_h, θ_d, φ_d at the centre of every cell, each (90, 90, 180)."""
    th = ((np.arange(RES_TH) + 0.5) / RES_TH) ** 2 * (np.pi / 2)
    td = (np.arange(RES_TD) + 0.5) / RES_TD * (np.pi / 2)
    pd = (np.arange(RES_PD) + 0.5) / RES_PD * np.pi
    return np.meshgrid(th, td, pd, indexing="ij")


def merl_lookup(table, o, i):
    """Nearest-cell MERL value ρ(o, i), RGB (..., 3); 0 below the horizon or for invalid cells."""
    o = np.asarray(o, float)
    i = np.asarray(i, float)
    o, i = np.broadcast_arrays(o, i)
    th, _, td, pd = to_half_diff(o, i)
    ih, it, ip = merl_indices(th, td, pd)
    val = np.moveaxis(table[:, ih, it, ip], 0, -1)
    up = (o[..., 2] > 0) & (i[..., 2] > 0)
    return np.where(up[..., None], np.maximum(val, 0.0), 0.0)


def synthesize_merl(brdf) -> np.ndarray:
    """Tabulate any BRDF (object with `eval(o, i)`) at MERL cell centres; -1 below the horizon."""
    th, td, pd = cell_centres()
    out = np.empty((3, RES_TH, RES_TD, RES_PD))
    for k in range(RES_TH):            # one θ_h slab at a time keeps memory small
        o, i = from_half_diff(th[k], td[k], pd[k])
        val = brdf.eval(o, i)
        up = (o[..., 2] > 1e-6) & (i[..., 2] > 1e-6)
        out[:, k] = np.moveaxis(np.where(up[..., None], val, -1.0), -1, 0)
    return out
