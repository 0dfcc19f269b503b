"""Helpers for the render tests: bordered cubemaps of analytic functions, small environments,
and the selftest program (imported by tests/render/test_sg_*.py)."""

from __future__ import annotations

import numpy as np

from sgpipe.render import opencl
from sgpipe.render.envdata import CubeChain, EnvData

SELFTEST_NV = 4


def bordered_dirs(n: int) -> np.ndarray:
    """Unit directions of every texel of a bordered "cube6v_b1" level: (6(n+2), n+2, 3)."""
    j = np.arange(n + 2)
    s = (j - 0.5) / n
    a = 2 * s - 1
    A, Bm = np.meshgrid(a, a)            # A: columns (s), Bm: rows (t)
    one = np.ones_like(A)
    faces = [np.stack([one, -Bm, -A], -1), np.stack([-one, -Bm, A], -1),
             np.stack([A, one, Bm], -1), np.stack([A, -one, -Bm], -1),
             np.stack([A, -Bm, one], -1), np.stack([-A, -Bm, -one], -1)]
    d = np.concatenate(faces, 0)
    return d / np.linalg.norm(d, axis=-1, keepdims=True)


def linear_env(c0=1.0, g=(0.5, 0.3, -0.2), face_res=32, lam0=None) -> tuple[EnvData, callable]:
    """Environment L(d) = c0 + g·d (RGB equal). Its normalised SG convolution is exactly
    V_λ(p) = c0 + A(λ) g·p (A = coth λ − 1/λ), stored per pyramid level; the MIP chain holds
    L at texel centres. Returns (EnvData, L)."""
    g = np.asarray(g, float)
    f = lambda d: c0 + np.asarray(d, float) @ g
    A = lambda lam: 1.0 / np.tanh(lam) - 1.0 / lam
    lam0 = lam0 or face_res ** 2 / 4.0
    lams = [lam0 / 2.0 ** k for k in range(12) if lam0 / 2.0 ** k > 1.0]
    levels = []
    for k, lam in enumerate(lams):
        n = max(2, face_res >> min(k, 3))
        d = bordered_dirs(n)
        v = c0 + A(lam) * (d @ g)
        levels.append(np.repeat(v[..., None], 3, -1))
    mips = []
    n = face_res
    while n >= 1:
        d = bordered_dirs(n)
        mips.append(np.repeat(f(d)[..., None], 3, -1))
        n //= 2
    env = EnvData(pyramid=CubeChain.from_levels(levels), lambdas=np.array(lams, np.float32),
                  log_ratio=float(np.log(2.0)), mean=np.full(3, c0, np.float32),
                  mip=CubeChain.from_levels(mips),
                  light_axes=np.array([[0, 1.0, 0]], np.float32),
                  light_lambda=np.array([1e-4], np.float32),
                  light_mu=np.full((1, 3), c0, np.float32))
    return env, f


def selftest_program(fh_mode="sigmoid", nv=SELFTEST_NV):
    from sgpipe.render.headers import fh_coefficients, kernel_headers
    a, c3, c2, c1, c0 = fh_coefficients()
    ctx, q = opencl.get_context()
    d = {"NV": nv, "FH_A": a, "FH_C3": c3, "FH_C2": c2, "FH_C1": c1, "FH_C0": c0}
    if fh_mode == "table":
        d["FH_TABLE"] = 1
    prg = opencl.build_program(ctx, "selftest", d, headers=kernel_headers(fh_mode))
    return ctx, q, prg


def run_kernel_table(name, n, inputs, outputs):
    """run_kernel with the program built in f_h table mode."""
    return run_kernel(name, n, inputs, outputs, fh_mode="table")


def run_kernel(name, n, inputs, outputs, fh_mode="sigmoid", nv=SELFTEST_NV):
    """Launch selftest kernel `name` over n items. inputs: list of arrays/scalars (arrays are
    uploaded); outputs: list of (shape, dtype); nv: the program's NV. Returns the output
    arrays."""
    ctx, q, prg = selftest_program(fh_mode, nv)
    args = []
    for x in inputs:
        if isinstance(x, np.ndarray) and x.ndim >= 1:
            args.append(opencl.to_device(ctx, x, dtype=x.dtype))
        else:
            args.append(x)
    outs = [opencl.empty_device(ctx, int(np.prod(s)) * np.dtype(dt).itemsize) for s, dt in outputs]
    import pyopencl as cl
    cl.Kernel(prg, name)(q, (n,), None, *args, *outs)
    return [opencl.read_back(q, b, s, dt) for b, (s, dt) in zip(outs, outputs)]


def f4(a) -> np.ndarray:
    a = np.asarray(a, np.float32)
    return np.concatenate([a, np.zeros(a.shape[:-1] + (4 - a.shape[-1],), np.float32)], -1)


def cube_bilinear_np(chain, level: int, d) -> np.ndarray:
    """numpy port of the contract's bordered lookup (docs/ARTIFACTS.md envmap/) → (n, 3)."""
    from sgpipe.core.maps import dir_to_cubemap
    n = int(chain.res[level])
    w = n + 2
    off = int(chain.offsets[level])
    img = chain.texels[off:off + 6 * w * w, :3].reshape(6, w, w, 3)
    face, s, t = dir_to_cubemap(np.asarray(d, float))
    u, v = s * n + 0.5, t * n + 0.5
    j0, i0 = np.minimum(np.floor(u).astype(int), n), np.minimum(np.floor(v).astype(int), n)
    fx, fy = (u - j0)[:, None], (v - i0)[:, None]
    return ((1 - fx) * (1 - fy) * img[face, i0, j0] + fx * (1 - fy) * img[face, i0, j0 + 1]
            + (1 - fx) * fy * img[face, i0 + 1, j0] + fx * fy * img[face, i0 + 1, j0 + 1])


# --- fake upstream artifacts in the documented layouts (docs/ARTIFACTS.md) ----------------
def latlong_dirs_and_weights(h, w, ss=1):
    """Supersampled lat-long directions (h·ss, w·ss, 3) and exact solid angles."""
    from sgpipe.core.maps import latlong_dir, latlong_solid_angles
    v = (np.arange(h * ss) + 0.5) / (h * ss)
    u = (np.arange(w * ss) + 0.5) / (w * ss)
    return latlong_dir(u[None, :], v[:, None]), latlong_solid_angles(h * ss, w * ss)


def write_env_artifacts(folder, latlong: np.ndarray, N: int = 16, n_light_lobes: int = 12):
    """envmap/ artifacts by brute force from a small lat-long map: the normalised Γ_L pyramid
    (λ_0 = N²/4, ratio 2, down to λ ≤ 1), a box MIP chain (texel means by supersampling),
    and a non-negative least-squares SG light fit on fixed axes."""
    from pathlib import Path
    from scipy.optimize import nnls
    from sgpipe.core.sphere import fibonacci_sphere
    from sgpipe.io import write_exr, write_npz
    folder = Path(folder)
    h, w = latlong.shape[:2]
    dirs, om = latlong_dirs_and_weights(h, w)
    D = dirs.reshape(-1, 3)
    Lw = latlong.reshape(-1, 3) * om.reshape(-1, 1)
    lam0 = N * N / 4.0
    lams = []
    lam = lam0
    while True:
        lams.append(lam)
        if lam <= 1.0:
            break
        lam /= 2.0
    res = []
    for k, lam in enumerate(lams):
        n = max(2, N >> min(k, 3))
        p = bordered_dirs(n).reshape(-1, 3)
        wts = np.exp(lam * (p @ D.T - 1.0))
        V = (wts @ Lw) / (wts @ om.reshape(-1, 1))
        write_exr(folder / "pyramid" / f"level_{k:02d}.exr", V.reshape(6 * (n + 2), n + 2, 3))
        res.append(n)
    mean = Lw.sum(0) / om.sum()
    write_npz(folder / "pyramid.npz", {"lambdas": np.array(lams), "face_res": np.array(res),
                                       "mean": mean, "ratio": np.float64(2.0),
                                       "border": np.int32(1)})
    # box MIP chain: level 0 = texel means (4×4 sub-samples, nearest lat-long texel), coarser
    # levels = 2×2 averages; borders = the neighbouring face's texel at the border direction
    from sgpipe.core.maps import dir_to_cubemap, dir_to_latlong

    def face_dirs(n, sub):
        c = (np.arange(n * sub) + 0.5) / (n * sub)
        a = 2 * c - 1
        A, Bm = np.meshgrid(a, a)
        one = np.ones_like(A)
        f = [np.stack([one, -Bm, -A], -1), np.stack([-one, -Bm, A], -1),
             np.stack([A, one, Bm], -1), np.stack([A, -one, -Bm], -1),
             np.stack([A, -Bm, one], -1), np.stack([-A, -Bm, -one], -1)]
        d = np.stack(f)
        return d / np.linalg.norm(d, axis=-1, keepdims=True)

    def lookup(d):
        u, v = dir_to_latlong(d)
        i = np.clip((v * h).astype(int), 0, h - 1)
        return latlong[i, np.clip((u * w).astype(int), 0, w - 1)]

    def bordered(inner):
        n = inner.shape[1]
        out = np.zeros((6, n + 2, n + 2, 3))
        out[:, 1:-1, 1:-1] = inner
        d = bordered_dirs(n).reshape(6, n + 2, n + 2, 3)
        edge = np.ones((n + 2, n + 2), bool)
        edge[1:-1, 1:-1] = False
        fc, s_, t_ = dir_to_cubemap(d[:, edge])
        out[:, edge] = inner[fc, np.clip((t_ * n).astype(int), 0, n - 1),
                             np.clip((s_ * n).astype(int), 0, n - 1)]
        return out.reshape(6 * (n + 2), n + 2, 3)

    sub = 4
    fine = lookup(face_dirs(N, sub)).reshape(6, N, sub, N, sub, 3).mean((2, 4))
    mres, lev, m = [], fine, 0
    while True:
        write_exr(folder / "mip" / f"cube_{m:02d}.exr", bordered(lev))
        mres.append(lev.shape[1])
        if lev.shape[1] == 1:
            break
        n2 = lev.shape[1] // 2
        lev = lev.reshape(6, n2, 2, n2, 2, 3).mean((2, 4))
        m += 1
    write_npz(folder / "mip.npz", {"cube_res": np.array(mres, np.int32), "N": np.int32(N)})
    axes = fibonacci_sphere(n_light_lobes)
    lam_l = 4.0
    Bm = np.exp(lam_l * (D @ axes.T - 1.0))                     # (texels, K)
    sw = np.sqrt(om.reshape(-1))
    amp = np.stack([nnls(Bm * sw[:, None], latlong.reshape(-1, 3)[:, c] * sw)[0]
                    for c in range(3)], -1)
    write_npz(folder / "light_sg.npz", {"axes": axes, "sharpness": np.full(len(axes), lam_l),
                                        "amplitude": amp})
    (folder / "manifest.json").write_text("{}\n")


def write_fit_artifacts(folder, name, model, params):
    """fit/<name>/ microfacet.npz + ndf_sg.npz (analytic SG of the NDF) from sgpipe.brdf."""
    from pathlib import Path
    from sgpipe.brdf import make_brdf
    from sgpipe.io import write_npz
    folder = Path(folder)
    b = make_brdf(model, params)
    p = b.microfacet_params()
    keep = ("kd", "ks", "g_scale", "diffuse", "fresnel", "f0", "eta", "k", "shadowing",
            "alpha_u", "alpha_v", "shadow_table")
    write_npz(folder / name / "microfacet.npz", {k: np.asarray(p[k]) for k in keep})
    sg = b.ndf_model.sg_analytic() if b.ndf_model is not None else None
    lobes = [sg] if sg is not None and b.has_specular else []
    write_npz(folder / name / "ndf_sg.npz", {
        "axis": np.array([[0, 0, 1.0]] * len(lobes)).reshape(-1, 3),
        "sharpness": np.array([x[0] for x in lobes], float),
        "amplitude": np.array([x[1] for x in lobes], float)})
    (folder / "manifest.json").write_text("{}\n")
    return b
