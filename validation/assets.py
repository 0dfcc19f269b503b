"""Generated scene inputs, written on demand into validation/generated/ (git-ignored): the
thick bowl, lat-long maps with hard-edged lamps or a low sun (sgpipe.experiments.corpus.assets),
small kd / ks textures and a glTF ball with textured roughness (validation.gltf). A scene names
one as `../generated/<name>`; every generator is a pure function of its name (fixed seeds), so
the files are the same on every machine."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

GENERATED_DIR = Path(__file__).resolve().parent / "generated"
PREFIX = "../generated/"


def _bowl(path: Path) -> None:
    from sgpipe.experiments.corpus import assets
    from sgpipe.io.mesh import write_obj
    v, f, n = assets.bowl_mesh()
    write_obj(path, v, f, normals=n)


def _lamps(seed: int):
    def make(path: Path) -> None:
        from sgpipe.experiments.corpus import assets
        from sgpipe.io.exr import write_exr
        write_exr(path, assets.lamp_map(assets.draw_lamps(np.random.default_rng(seed), 4)))
    return make


def _sun(seed: int, low: bool):
    def make(path: Path) -> None:
        from sgpipe.experiments.corpus import assets
        from sgpipe.io.exr import write_exr
        write_exr(path, assets.sky_sun_map(assets.draw_sun(np.random.default_rng(seed),
                                                           low=low)))
    return make


def texture_rgb(seed: int, size: int, lo: float, hi: float) -> np.ndarray:
    """A small random RGB texture in [lo, hi] (no symmetry: a flipped or shifted lookup shows)."""
    return np.random.default_rng(seed).uniform(lo, hi, (size, size, 3))


def _texture(seed: int, size: int, lo: float, hi: float):
    def make(path: Path) -> None:
        from sgpipe.io.exr import write_exr
        write_exr(path, texture_rgb(seed, size, lo, hi))
    return make


def _rough_metal_ball(path: Path) -> None:
    from validation.gltf import write_rough_metal_ball
    write_rough_metal_ball(path)


GENERATORS = {
    "bowl.obj": _bowl,
    "lamps_seed4.exr": _lamps(4),
    "sky_low_sun_seed5.exr": _sun(5, True),
    "kd_texture_8.exr": _texture(11, 8, 0.1, 1.0),
    "ks_texture_6.exr": _texture(12, 6, 0.0, 1.0),
    "rough_metal_ball.glb": _rough_metal_ball,
}


def ensure(name: str, folder: Path = GENERATED_DIR) -> Path:
    """validation/generated/<name>, written first if missing."""
    if name not in GENERATORS:
        raise KeyError(f"no generator for {name!r}; known: {sorted(GENERATORS)}")
    path = folder / name
    if not path.is_file():
        folder.mkdir(parents=True, exist_ok=True)
        tmp = path.with_name(path.stem + ".tmp" + path.suffix)
        GENERATORS[name](tmp)
        tmp.replace(path)
    return path


def _strings(node):
    if isinstance(node, str):
        yield node
    elif isinstance(node, dict):
        for v in node.values():
            yield from _strings(v)
    elif isinstance(node, list):
        for v in node:
            yield from _strings(v)


def ensure_for_scene(path: Path) -> list[Path]:
    """Generate every `../generated/<name>` input a scene YAML names."""
    data = yaml.safe_load(Path(path).read_text())
    return [ensure(s[len(PREFIX):]) for s in _strings(data) if s.startswith(PREFIX)]
