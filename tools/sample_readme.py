"""data_samples/README.md, rendered from the files just written (sizes) and their facts."""

from __future__ import annotations

from pathlib import Path

FILES = (
    ("sky_sun.exr", "HDR lat-long sky: zenith-to-horizon gradient, darker ground, and a 0.75 deg "
     "sun of radiance 5e4 (RGB 1, 0.92, 0.82 x 5e4) at elevation 35 deg, phi 110 deg",
     "`sample_envmaps.make_sky_sun`: sky = texel mean over 4x4 equal-solid-angle strata; "
     "sun = exact-ish cap coverage (64x64 strata per texel near the sun) x radiance, added on "
     "top of the sky; float16 EXR"),
    ("sky_sun.png", "preview of sky_sun.exr", "`write_png`, exposure 0 (clamp, sRGB)"),
    ("studio.exr", "HDR lat-long studio: 4 rectangular softboxes (key warm, fill blue, rim "
     "magenta strip, top green-white strip through the zenith) on a dim background "
     "0.03 x (1 + 0.5 y)", "`sample_envmaps.make_studio`: hard-edged gnomonic rectangles, "
     "8x8 equal-solid-angle strata per texel; float16 EXR"),
    ("studio.png", "preview of studio.exr", "`write_png`, exposure -2"),
    ("white.exr", "constant radiance 1 (white furnace), 64x32", "float16 EXR"),
    ("env_info.json", "analytic facts and texel integrals of the three maps",
     "see *Env map facts* below"),
    ("sphere.obj", "unit UV sphere, 72 x 36 segments, v/vt/vn", "`sample_meshes.uv_sphere`"),
    ("teapot.obj", "Utah teapot, welded, smooth outward normals, v/vn (no vt)",
     "`sample_meshes.teapot` from `tools/teapot_data.py` (Newell's 32 patches / 306 points)"),
    ("floor.obj", "6 x 6 plane at y = 0, 100 x 100 quads, normal +Y, v/vt/vn",
     "`sample_meshes.floor_plane`"),
    ("normal_map.png", "256^2 tangent-space normal map (4x4 round bumps + diagonal ripple), "
     "8-bit, (n * 0.5 + 0.5) * 255, linear (no sRGB curve), z up, green = +v (OpenGL style)",
     "`make_data_samples.make_normal_map` (analytic gradient of the height field)"),
    ("normal_map.exr", "the same normals unquantised to 8 bits: float16, n * 0.5 + 0.5", "idem"),
    ("bump_height.exr", "the height field the normals come from, in uv units (1 channel, float32)",
     "`make_data_samples.bump_height`"),
    ("textured_ball.glb", "glTF 2.0 metal-rough asset: the unit UV sphere with 256 x 128 "
     "textures: base colour (8 x 4 tiles of four paints, sRGB), metallic-roughness (roughness "
     "0.05 -> 0.8 along u in G, metalness 1 in two bands of v in B: sharp edges), normal "
     "(normal_map.png's bumps at 128^2); factors 1",
     "`tools/sample_gltf.py` (pygltflib, PNGs by Pillow)"),
)


def _size(path: Path) -> str:
    b = path.stat().st_size
    return f"{b / 1024:.1f} KiB" if b < 1 << 20 else f"{b / (1 << 20):.2f} MiB"


def _fmt(xs) -> str:
    return "(" + ", ".join(f"{x:.6g}" for x in xs) + ")"


def render(out: Path, facts: dict) -> str:
    rows = ["| file | what | how | size |", "|---|---|---|---|"]
    total = 0
    for name, what, how in FILES:
        total += (out / name).stat().st_size
        rows.append(f"| `{name}` | {what} | {how} | {_size(out / name)} |")
    rows.append("| `README.md` | this file | `tools/sample_readme.py` | - |")
    sun = facts["sky_sun.exr"]["sun"]
    sky, studio, white = facts["sky_sun.exr"], facts["studio.exr"], facts["white.exr"]
    tp = facts["teapot.obj"]
    boxes = "\n".join(
        f"| {b['name']} | {b['elevation_deg']:g} | {b['phi_deg']:g} | {b['half_width_deg']:g} x "
        f"{b['half_height_deg']:g} | {_fmt(b['radiance_rgb'])} | {b['solid_angle_sr']:.6g} | "
        f"{_fmt(b['power_rgb'])} |" for b in studio["softboxes"])
    return f"""# data_samples

Small reproducible inputs for tests, examples and benchmarks. **Every file here is written by
`tools/make_data_samples.py`**; do not edit them by hand:

    .venv/bin/python tools/make_data_samples.py [--out data_samples]

Two runs give byte-identical files (EXR/PNG through `sgpipe.io`, fixed-format OBJ/JSON);
`tests/test_data_samples.py` regenerates everything into a temporary folder and compares bytes.
Total size of the files below: {total / (1 << 20):.2f} MiB.

| file | what | how | size |
|---|---|---|---|
{chr(10).join(rows[2:])}

## Conventions

- Lat-long maps follow docs/CONVENTIONS.md: texel (row i, column j) of an H x W map covers
  theta in [pi i/H, pi (i+1)/H], phi in [2 pi j/W, 2 pi (j+1)/W]; direction
  (sin theta sin phi, cos theta, -sin theta cos phi); row 0 is +Y, u = 0 is -Z.
  Each texel stores the **mean** radiance over its footprint (equal-solid-angle strata), so
  `sum(texel * exact texel solid angle)` reproduces the analytic integrals. Exact texel solid
  angle: (2 pi / W) (cos theta_i - cos theta_(i+1)).
- PNG previews: `sgpipe.io.write_png`, scale by 2^exposure, clamp to [0, 1], sRGB curve.
- OBJ: triangles, counter-clockwise seen from outside, vertex normals outward and unit length
  (written with 6 decimals), `vt` with v up (v = 0 is the bottom row of an image), one `vt`/`vn`
  per `v` (`f a/a/a`). +Y up.
- `sphere.obj`: vt = (phi / 2 pi, 1 - theta / pi), so a lat-long texture shows direction d at
  the surface point d; the seam column is duplicated and each pole triangle has its own pole
  vertex. dP/du is the azimuthal direction (the conventions' default sphere tangent). Note
  dP/du x dP/dv points *inward* (lat-long images are mirror images seen from outside).
- `floor.obj`: x, z in [-3, 3], vt = ((x + 3) / 6, (3 - z) / 6): dP/du = +X, dP/dv = -Z = n x t.
- `teapot.obj`: Newell's Z-up data rotated to Y-up ((x, y, z) -> (x, z, -y), spout toward +X),
  centred in x and z, bottom pole at y = 0, scaled by {tp['scale']:.6f} so it fits the unit
  sphere about (0, height / 2, 0). Bounds {_fmt(tp['bounds'][0])} to {_fmt(tp['bounds'][1])}.
  Each patch is tessellated on a {tp['patch_grid']} x {tp['patch_grid']} grid; vertices are
  welded within each part (body with rim and bottom, lid, handle, spout: the parts intersect but
  share no vertices); normals are the analytic patch normals averaged over welded copies, the
  two axis poles (lid knob top, bottom centre) snapped to +-Y. Not watertight (the classic gap
  between lid and rim, the open spout, handle and spout ends inside the body); each part is
  consistently wound and outward. No `vt` (the per-patch parameterisation has seams; use the
  conventions' azimuthal tangent rule). Newell's bottom patches were added later by others.
- Normal map: texel (row r, col c) is at u = (c + 0.5) / 256, v = 1 - (r + 0.5) / 256;
  n = normalize(-dh/du, -dh/dv, 1) in the frame (dP/du, dP/dv, n): red along +u, green along
  +v (on `floor.obj` these are t = +X and b = n x t = -Z). Decode
  `n = texel / 255 * 2 - 1` (PNG) or `n = texel * 2 - 1` (EXR). Tiles seamlessly.

## Mesh sizes

| file | vertices | triangles |
|---|---|---|
| sphere.obj | {facts['sphere.obj']['vertices']} | {facts['sphere.obj']['faces']} |
| teapot.obj | {tp['vertices']} | {tp['faces']} |
| floor.obj | {facts['floor.obj']['vertices']} | {facts['floor.obj']['faces']} |

## Env map facts (`env_info.json`)

`power_rgb` = integral of L over the sphere; `irradiance_up_rgb` = integral of
L max(cos theta, 0), the irradiance at normal +Y; both summed from the stored float16 texels
with exact texel solid angles (and exact per-row integrals of cos theta).

- `sky_sun.exr` ({sky['size'][0]} x {sky['size'][1]}): power {_fmt(sky['power_rgb'])},
  irradiance up {_fmt(sky['irradiance_up_rgb'])}. Sun: direction {_fmt(sun['direction'])},
  angular radius {sun['angular_radius_deg']} deg, solid angle {sun['solid_angle_sr']:.6g} sr,
  radiance {_fmt(sun['radiance_rgb'])}, power L * Omega = {_fmt(sun['power_rgb'])}
  (from texels, map minus sky-only map: {_fmt(sun['power_from_texels_rgb'])}), irradiance on a
  surface facing it L pi sin^2 r = {_fmt(sun['irradiance_facing_rgb'])}. The sky alone
  integrates to {_fmt(sky['sky']['power_rgb'])}, so the sun dominates irradiance. The sun is
  added on top of the sky (disk radiance = sun + sky).
- `studio.exr` ({studio['size'][0]} x {studio['size'][1]}): power {_fmt(studio['power_rgb'])}
  from texels vs analytic 4 pi background + sum of L * Omega = {_fmt(studio['power_analytic_rgb'])}.
  Softbox = planar rectangle at unit distance along `center`, half-sides tan(half width) along
  `width_axis` = (cos phi, 0, sin phi) and tan(half height) along `height_axis` = center x
  width_axis; solid angle 4 atan(a b / sqrt(1 + a^2 + b^2)).

| box | elevation deg | phi deg | half angles deg | radiance | solid angle sr | power |
|---|---|---|---|---|---|---|
{boxes}

- `white.exr`: power {_fmt(white['power_rgb'])} (4 pi), irradiance up
  {_fmt(white['irradiance_up_rgb'])} (pi).
"""
