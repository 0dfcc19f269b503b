"""Host side of the OpenCL shading methods (`sgpipe.render.methods.METHODS`): uploads the static
scene data (environment, materials, SSDF PCA data, textures, lights) once, then shades compacted
G-buffer pixels per method with one kernel launch, its arguments bound to the registry's
parameter list by name.

    r = Renderer(env=EnvData.load(...), materials=pack_materials([...]), objects=[...])
    rgb = r.shade("sg", frame)          # frame: Frame (hit pixels of a GBuffer), → (n, 3)
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from sgpipe.render import opencl
from sgpipe.render.envdata import EnvData
from sgpipe.render.headers import fh_coefficients, kernel_headers
from sgpipe.render.materials import MaterialTable
from sgpipe.render.methods import KERNELS, PUBLISHED_SWITCHES, TORAL19_SWITCHES
from sgpipe.render.records import MAT_STRIDE, MaterialSlot, ObjectFloatSlot, ObjectSlot
from sgpipe.render.textures import Textures  # noqa: F401  (the renderer's texture set)


@dataclass
class VisObject:
    """SSDF PCA data of one object (visibility/<object>/ssdf_pca.npz, geometry faces)."""

    faces: np.ndarray      # (F, 3) int32 triangles of the SSDF mesh
    coeffs: np.ndarray     # (V, n) float32 per-vertex PCA coefficients
    mean: np.ndarray       # (R, R) float32
    basis: np.ndarray      # (n, R, R) float32
    max_distance: float = float(np.pi / 2)


@dataclass
class ObjectShading:
    """Per-object shading inputs: material index, optional SSDF data, optional normal map."""

    material: int
    vis: VisObject | None = None
    normal_map: int = -1


@dataclass
class Light:
    """Point (position) or directional (direction towards the light) SG light (Wang09 eq 32–33)."""

    kind: str                 # "point" | "directional"
    vector: tuple             # position (point) or direction to the light (directional)
    intensity: tuple          # RGB: radiant intensity I (point) / irradiance E (directional)
    radius: float = 0.0       # world radius (point) / tan of the angular radius (directional)


@dataclass
class Frame:
    """Compacted hit pixels of a G-buffer (the per-pixel kernel inputs)."""

    index: np.ndarray        # (n,) flat pixel indices
    shape: tuple
    normal: np.ndarray       # (n, 4) float32
    tangent: np.ndarray
    view: np.ndarray
    position: np.ndarray
    uv: np.ndarray           # (n, 2)
    obj: np.ndarray          # (n,) int32
    tri: np.ndarray          # (n,) int32 SSDF-mesh triangle (−1: none)
    bary: np.ndarray         # (n, 2) float32 SSDF-mesh barycentrics
    duv: np.ndarray | None = None  # (n, 4) UV derivatives (sgpipe.scene.footprint), or none

    @classmethod
    def from_gbuffer(cls, gb, vis_tri=None, vis_bary=None) -> "Frame":
        """Hit pixels of `gb`; SSDF triangles default to the traced triangles."""
        idx = np.flatnonzero(gb.hit.reshape(-1))
        f4 = lambda a: np.concatenate([a.reshape(-1, 3)[idx], np.zeros((len(idx), 1))],
                                      1).astype(np.float32)
        tri = gb.triangle_id if vis_tri is None else vis_tri
        bary = gb.barycentrics if vis_bary is None else vis_bary
        tangent = f4(gb.tangent)     # w: the normal map's handedness (shading.h pixel_init)
        tangent[:, 3] = 1.0 if gb.handedness is None else gb.handedness.reshape(-1)[idx]
        return cls(index=idx, shape=gb.hit.shape, normal=f4(gb.normal), tangent=tangent,
                   view=f4(gb.view), position=f4(gb.position),
                   uv=gb.uv.reshape(-1, 2)[idx].astype(np.float32),
                   obj=gb.object_id.reshape(-1)[idx].astype(np.int32),
                   tri=np.asarray(tri).reshape(-1)[idx].astype(np.int32),
                   bary=np.asarray(bary, np.float32).reshape(-1, 2)[idx])

    def to_image(self, rgb: np.ndarray, background: np.ndarray | None = None) -> np.ndarray:
        img = (np.zeros(self.shape + (3,), np.float32) if background is None
               else np.array(background, np.float32).reshape(self.shape + (3,)))
        img.reshape(-1, 3)[self.index] = rgb
        return img


class Renderer:
    """Static scene data on the OpenCL device + one launch per method and frame."""

    def __init__(self, *, env: EnvData, materials: MaterialTable, objects: list[ObjectShading],
                 textures: Textures | None = None, lights: list[Light] = (),
                 env_scale: float = 1.0, nv: int | None = None, fh_mode: str = "table",
                 gmm_taps: int = 16, gmm_carry: str = "warp", gmm_points: bool = True,
                 sg_wang09_adds: tuple[str, ...] = (), gmm_toral19_adds: tuple[str, ...] = (),
                 transport_green06_adds: tuple[str, ...] = (),
                 vmf_han07_adds: tuple[str, ...] = (), nm_sh_han07_adds: tuple[str, ...] = (),
                 materials_toral19: MaterialTable | None = None):
        self.ctx, self.queue = opencl.get_context()
        self.env, self.materials, self.objects = env, materials, list(objects)
        self.env_scale = float(env_scale)
        self.headers = kernel_headers(fh_mode)
        self.fh_mode = fh_mode
        self.sg_wang09_adds = tuple(sg_wang09_adds)
        self.gmm_toral19_adds = tuple(gmm_toral19_adds)
        self.transport_green06_adds = tuple(transport_green06_adds)
        self.vmf_han07_adds = tuple(vmf_han07_adds)
        self.nm_sh_han07_adds = tuple(nm_sh_han07_adds)
        # `gmm_toral19`'s material table (its published per-view fit); None: `materials`'
        self.materials_toral19 = materials_toral19
        self._bindings: dict[str, dict] = {}
        self.gmm_taps = int(gmm_taps)
        self.gmm_carry = {"none": 0, "rotate": 1, "warp": 2}[gmm_carry]   # GMM_ROTATE
        self.gmm_points = bool(gmm_points)   # gmm: residual MIP chain + exact point set
        vis = [o.vis for o in self.objects if o.vis is not None]
        nv = int(nv if nv is not None else max([v.coeffs.shape[1] for v in vis] or [0]))
        self.nv = -(-nv // 4) * 4          # kernels read the PCA terms as float4
        self.timings: dict[str, float] = {}
        self._kernels: dict[str, object] = {}
        # material textures with MIP chains: lookups filtered over each pixel's footprint
        self.textured = any(e.mip for e in (textures or Textures()).entries)
        self._upload(textures or Textures(), list(lights))
        # the normal-map and transport methods' buffers, empty until their data is attached
        from sgpipe.render.normalmap_data import NormalMapData
        from sgpipe.render.transport_data import transport_arrays, upload_transport
        self.static.update(NormalMapData.empty(len(self.objects)).device_buffers(self.ctx))
        upload_transport(self, transport_arrays([None] * len(self.objects),
                                                np.zeros((0, 3), np.float32)))

    # -- static data ----------------------------------------------------------------------
    def _object_records(self):
        """(int8 records, float4 records, SSDF faces, coefficients, basis + mean data)."""
        nv = self.nv
        objs = np.zeros((max(len(self.objects), 1), 8), np.int32)
        objf = np.zeros((max(len(self.objects), 1), 4), np.float32)
        faces, coeffs, data = [], [], []
        nf = nvert = ndata = 0
        S = ObjectSlot
        for k, o in enumerate(self.objects):
            rec = objs[k]
            rec[S.MAT], rec[S.FACE0], rec[S.VERT0], rec[S.RES], rec[S.NMAP] = \
                o.material, nf, nvert, 1, o.normal_map
            objf[k, ObjectFloatSlot.MAXD] = np.pi / 2
            v = o.vis
            if v is None or nv == 0:
                continue
            n_terms = min(v.coeffs.shape[1], nv)
            res = v.mean.shape[0]
            c = np.zeros((len(v.coeffs), nv), np.float32)
            c[:, :n_terms] = v.coeffs[:, :n_terms]
            b = np.zeros((res, res, nv), np.float32)
            b[..., :n_terms] = np.moveaxis(np.asarray(v.basis[:n_terms], np.float32), 0, -1)
            rec[S.HAS_SSDF], rec[S.BASIS], rec[S.MEAN], rec[S.RES] = 1, ndata, ndata + b.size, res
            objf[k, ObjectFloatSlot.MAXD] = v.max_distance
            faces.append(np.asarray(v.faces, np.int32).reshape(-1))
            coeffs.append(c.reshape(-1))
            data += [b.reshape(-1), np.asarray(v.mean, np.float32).reshape(-1)]
            nf += len(v.faces)
            nvert += len(v.coeffs)
            ndata += b.size + v.mean.size
        cat = lambda parts, dt: np.concatenate(parts).astype(dt) if parts else np.zeros(1, dt)
        return objs, objf, cat(faces, np.int32), cat(coeffs, np.float32), cat(data, np.float32)

    def _upload(self, textures: Textures, lights: list[Light]) -> None:
        """Device buffers and scalars of the scene, keyed by the kernels' parameter names."""
        dev = lambda a, dt=np.float32: opencl.to_device(self.ctx, a, dtype=dt)
        objs, objf, faces, coeffs, data = self._object_records()
        texels, texinfo, texaff = textures.pack()
        e = self.env
        lrec = np.zeros((max(len(lights), 1), 2, 4), np.float32)
        for k, L in enumerate(lights):
            lrec[k, 0, :3] = L.vector
            lrec[k, 0, 3] = 0.0 if L.kind == "point" else 1.0
            lrec[k, 1, :3] = L.intensity
            lrec[k, 1, 3] = L.radius
        m = self.materials
        from pyopencl import cltypes
        self.static = dict(
            objs=dev(objs, np.int32), objf=dev(objf), vfaces=dev(faces, np.int32),
            coeffs=dev(coeffs), ssdf_data=dev(data),
            mats=dev(m.records), lobes=dev(m.lobes.reshape(-1, 4)), tables=dev(m.tables),
            gmm=dev(m.gmm), ndf_info=dev(m.ndf_info, np.int32),
            texels=dev(texels), texinfo=dev(texinfo, np.int32),
            texaff=dev(texaff.reshape(-1, 4)),
            pyr=dev(e.gamma.texels), pyr_off=dev(e.gamma.offsets, np.int32),
            pyr_res=dev(e.gamma.res, np.int32), pyr_lam=dev(e.lambdas), pyr_n=len(e.lambdas),
            pyr_log_ratio=e.log_ratio,
            env_mean=cltypes.make_float4(*[float(c) for c in e.mean], 0.0),
            pyr_pts=dev(e.point_records().reshape(-1, 4)), n_pts=len(e.point_dirs),
            pyr_raw=dev(e.raw.texels if e.raw is not None else np.zeros((1, 4), np.float32)),
            raw_n=0 if e.raw is None else int(e.raw.res[0]),
            mip=dev(e.mip.texels), mip_off=dev(e.mip.offsets, np.int32),
            mip_res=dev(e.mip.res, np.int32), mip_n=len(e.mip.res),
            env_sg=dev(e.light_records().reshape(-1, 4)), n_env_sg=len(e.light_lambda),
            env_scale=self.env_scale, lights=dev(lrec.reshape(-1, 4)), n_lights=len(lights))

    def defines(self, method: str) -> dict:
        """Compile-time defines of `method`'s program: NV, f_h, and the registry's per-method
        ones (lobe counts of the material table, gmm taps)."""
        a, c3, c2, c1, c0 = fh_coefficients()
        d = {"NV": self.nv, "FH_A": a, "FH_C3": c3, "FH_C2": c2, "FH_C1": c1, "FH_C0": c0}
        if self.fh_mode == "table":
            d["FH_TABLE"] = 1
        mats = self.method_materials(method)
        per_scene = {"MAX_NDF_LOBES": max(1, mats.max_lobes),
                     "MAX_GMM_LOBES": max(1, mats.max_gmm_lobes),
                     "GMM_TAPS": max(1, self.gmm_taps), "GMM_ROTATE": self.gmm_carry}
        d.update({k: per_scene[k] for k in KERNELS[method].defines})
        d.update(self.env.rotation_defines())     # render.environment_rotation (cubemap.h)
        given_back = self._given_back(method)
        for k, v in KERNELS[method].fixed_defines:
            if k in given_back:
                continue
            if v is None:
                d.pop(k, None)
            else:
                d[k] = v
        return d

    def rotate_environment(self, rotation) -> None:
        """Turn the environment by `rotation` (3×3 world ← map, None: no change) for every
        method: EnvData.rotated (lookups through cubemap.h's defines, the point set and SG
        light axes re-uploaded turned); programs rebuild with the new defines."""
        if rotation is None:
            return
        self.env = self.env.rotated(rotation)
        dev = lambda a: opencl.to_device(self.ctx, a)  # noqa: E731
        self.static.update(pyr_pts=dev(self.env.point_records().reshape(-1, 4)),
                           env_sg=dev(self.env.light_records().reshape(-1, 4)))
        self._kernels.clear()

    def _given_back(self, method: str) -> set[str]:
        """The defines of a published variant's switches that the config gives back."""
        if method not in PUBLISHED_SWITCHES:
            return set()
        adds = getattr(self, f"{method}_adds")        # the constructor's <method>_adds
        return {k for name in adds for k, _ in PUBLISHED_SWITCHES[method][name]}

    def method_materials(self, method: str) -> MaterialTable:
        """The material table `method` reads: gmm_toral19's published fit unless `fit` is
        given back."""
        if (method == "gmm_toral19" and "fit" not in self.gmm_toral19_adds
                and self.materials_toral19 is not None):
            return self.materials_toral19
        return self.materials

    def method_bindings(self, method: str) -> dict:
        """The values `method` binds beyond `static` (built on first use): for gmm and
        gmm_toral19 the MIP chain the lobes read — the cube chain without the point set beside
        the points' exact vMF sum (render.gmm_points; the subtraction costs ~0.4 s at N = 128),
        else the whole cube chain, or Töral19's dual-paraboloid chain —, gmm_toral19's
        material table, and vmf_han07's SH lighting tables (han07_env)."""
        if method in self._bindings:
            return self._bindings[method]
        e, out = self.env, {}
        dev = lambda a, dt=np.float32: opencl.to_device(self.ctx, a, dtype=dt)  # noqa: E731
        if any(name == "gmm_mip" for _, name in KERNELS[method].parameters):
            adds = self.gmm_toral19_adds if method == "gmm_toral19" else tuple(TORAL19_SWITCHES)
            if "cube_chain" not in adds:
                dp = e.dp_chain()
                out.update(gmm_mip=dev(dp.texels), gmm_mip_off=dev(dp.offsets, np.int32),
                           gmm_mip_res=dev(dp.res, np.int32), gmm_mip_n=len(dp.res),
                           gmm_dp_b=dp.b, n_gmm_pts=0)
            else:
                res_mip = e.residual_mip() if self.gmm_points and "points" in adds else e.mip
                out.update(gmm_mip=(self.static["mip"] if res_mip is e.mip
                                    else dev(res_mip.texels)),
                           gmm_mip_off=self.static["mip_off"], gmm_mip_res=self.static["mip_res"],
                           gmm_mip_n=self.static["mip_n"], gmm_dp_b=1.0,
                           n_gmm_pts=len(e.point_dirs) if res_mip is not e.mip else 0)
        if method == "vmf_han07":       # Han07 §8: the map's SH and the L' table of views
            from sgpipe.render.han07_env import environment_sh8
            out["nm_env_sh8"] = dev(environment_sh8(e))
        mats = self.method_materials(method)
        if mats is not self.materials:
            out.update(mats=dev(mats.records), gmm=dev(mats.gmm))
        self._bindings[method] = out
        return out

    def kernel(self, method: str):
        """The method's kernel (program built once per context and defines; kernel reused)."""
        if method not in self._kernels:
            name = KERNELS[method].kernel
            t0 = time.perf_counter()
            prg = opencl.build_program(self.ctx, name, self.defines(method), headers=self.headers)
            self.timings.setdefault(f"{method}_build_s", time.perf_counter() - t0)
            import pyopencl as cl
            self._kernels[method] = cl.Kernel(prg, name)
        return self._kernels[method]

    # -- per frame ------------------------------------------------------------------------
    def upload_frame(self, fr: Frame) -> dict:
        """The frame's device buffers, keyed by the kernels' parameter names."""
        dev = lambda a, dt=np.float32: opencl.to_device(self.ctx, a, dtype=dt)
        return dict(n=len(fr.index), gnrm=dev(fr.normal), gtan=dev(fr.tangent),
                    gview=dev(fr.view), gpos=dev(fr.position), guv=dev(fr.uv),
                    gobj=dev(fr.obj, np.int32), gtri=dev(fr.tri, np.int32), gbary=dev(fr.bary),
                    gduv=dev(fr.duv if fr.duv is not None
                             else np.zeros((max(len(fr.index), 1), 4))),
                    pxmat=opencl.empty_device(self.ctx, 4 * MAT_STRIDE * (
                        max(len(fr.index), 1) if self._per_pixel_materials else 1)),
                    out=opencl.empty_device(self.ctx, 16 * max(len(fr.index), 1)))

    @property
    def emissive(self) -> bool:
        """Does a material emit (gltf_pbr `emissive`)? Then the render stage adds the
        auxiliary kernel `emission` (kernels/emit_shade.cl) to every method's image."""
        r = self.materials.records
        return bool(np.any(r[:, MaterialSlot.EMIT:MaterialSlot.EMIT + 3] > 0))

    @property
    def _per_pixel_materials(self) -> bool:
        """Does a material take its parameters from textures per pixel (pixel_init writes
        each such pixel's record into the frame's `pxmat`)?"""
        r = self.materials.records
        return bool(np.any(r[:, [MaterialSlot.BCTEX, MaterialSlot.MRTEX, MaterialSlot.ANTEX]] >= 0))

    def shade(self, method: str, fr: Frame | dict, *, flags: int = 0, fis_samples: int = 40,
              gmm_interpolate: bool = True, mip_coverage: float = 0.9, seed: int = 0):
        """Radiance (n, 3) of the frame's pixels with an OpenCL method of METHODS (or an
        auxiliary kernel of AUX_KERNELS); `flags`: records.KernelFlag bits."""
        g = fr if isinstance(fr, dict) else self.upload_frame(fr)
        n = g["n"]
        if n == 0:
            return np.zeros((0, 3), np.float32)
        kern = self.kernel(method)
        values = {**self.static, **self.method_bindings(method), **g, "flags": flags,
                  "coverage": mip_coverage, "interp": 1 if gmm_interpolate else 0,
                  "nsamp": fis_samples, "seed": seed}
        args = [_SCALAR.get(ctype, _as_is)(values[name])
                for ctype, name in KERNELS[method].parameters]
        # an explicit work-group size: left to the runtime, PoCL's CPU device picks groups so
        # large for big frames that the per-work-item private arrays of the normal-map
        # kernels (lobe lists) overflow its thread stack (a segfault from 128² on)
        kern(self.queue, (-(-n // LOCAL_SIZE) * LOCAL_SIZE,), (LOCAL_SIZE,), *args)
        return opencl.read_back(self.queue, g["out"], (n, 4))[:, :3]


#: work-group size of every shading launch (the global size is padded to a multiple; the
#: kernels return for gid ≥ n)
LOCAL_SIZE = 64


def _as_is(v):
    return v


#: Host types of the kernels' scalar parameters (buffers and float4 pass as they are).
_SCALAR = {"const int": np.int32, "const uint": np.uint32, "const float": np.float32}
