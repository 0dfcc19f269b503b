"""render.environment_rotation in the export: R (world ← map) from the run folder's resolved
config, the glTF quaternion of R and the SH9 coefficients of the turned environment
(Ramamoorthi & Hanrahan 2001: the cosine convolution is per band, so it commutes with rotation).

The cubemaps (KTX2, DDS, the glTF light's images) stay unturned (in the export's orientation,
sgpipe.export.orientation); the glTF light carries R (times the orientation's quarter turn) as
its `rotation`, irradiance_sh9.json holds the world-frame (turned) coefficients."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import yaml

from sgpipe.errors import BadInput

CONFIG_FILE = "config.resolved.yaml"
# the render stage's resolved config is the one its render used; a precompute-only run
# folder has the whole config beside the envmap artifacts
CONFIG_STAGES = ("render", "envmap")


def config_path(run_dir: Path) -> Path | None:
    """The resolved config the export reads render.environment_rotation from, or None."""
    for stage in CONFIG_STAGES:
        p = Path(run_dir) / stage / CONFIG_FILE
        if p.is_file():
            return p
    return None


def read_rotation(run_dir: Path) -> tuple[np.ndarray | None, dict | None, Path | None]:
    """(R (3, 3) world ← map or None, {axis, angle_deg} as configured, the config file)."""
    from sgpipe.config.sections.render import EnvironmentRotationSpec
    path = config_path(run_dir)
    if path is None:
        return None, None, None
    key = "render.environment_rotation"
    try:
        doc = yaml.safe_load(path.read_text())
    except yaml.YAMLError as e:
        raise BadInput(f"not valid YAML ({e})", file=path, key=key) from None
    spec = ((doc or {}).get("render") or {}).get("environment_rotation") \
        if isinstance(doc, dict) else None
    if spec is None:
        return None, None, path
    try:
        rot = EnvironmentRotationSpec(axis=tuple(float(v) for v in spec["axis"]),
                                      angle_deg=float(spec["angle_deg"]))
        if len(rot.axis) != 3:
            raise ValueError(f"axis: expected 3 numbers, got {list(rot.axis)}")
        rot.validate()
        if not -360.0 <= rot.angle_deg <= 360.0:
            raise ValueError(f"angle_deg: must be in [-360, 360], got {rot.angle_deg}")
    except (KeyError, TypeError, ValueError) as e:
        raise BadInput(f"bad environment rotation ({e})", file=path, key=key) from None
    R = rot.matrix()
    if R is None:
        return None, None, path
    return R, {"axis": list(rot.axis), "angle_deg": rot.angle_deg}, path


def gltf_quaternion(R: np.ndarray) -> list[float]:
    """glTF's unit quaternion [x, y, z, w] (scalar last, right-handed, as a node's `rotation`)
    of R: it turns the map direction d to R·d; sign chosen with w ≥ 0 (deterministic)."""
    from scipy.spatial.transform import Rotation
    q = Rotation.from_matrix(np.asarray(R, np.float64)).as_quat()    # (x, y, z, w)
    if q[3] < 0 or (q[3] == 0 and next(v for v in q[:3] if v != 0) < 0):
        q = -q
    return [float(v) + 0.0 for v in q]


def rotate_sh9(coeffs: np.ndarray, R: np.ndarray) -> np.ndarray:
    """(9, 3) SH9 coefficients of the map → those of the environment turned by R, f(Rᵀω)
    (sgpipe.render.transport_data.rotate_sh: the renderer's own rotation)."""
    from sgpipe.render.transport_data import rotate_sh
    return rotate_sh(np.asarray(coeffs, np.float64), R)


def rotate_sh9_document(doc: dict, R: np.ndarray, spec: dict) -> dict:
    """irradiance_sh9.json of the turned environment: world-frame coefficients, the rotation
    and the map-space coefficients it was made from."""
    out = dict(doc)
    out["irradiance"] = rotate_sh9(doc["irradiance"], R).tolist()
    out["radiance"] = rotate_sh9(doc["radiance"], R).tolist()
    out["environment_rotation"] = {
        **spec, "matrix": np.asarray(R, float).tolist(),
        "note": "render.environment_rotation (world <- map: what the map shows in direction "
                "d appears in world direction R d): irradiance and radiance are those of the "
                "turned environment in world coordinates; map_irradiance / map_radiance are "
                "the unturned map's (sgpipe's map space; export.json's orientation gives the "
                "frame of environment.ktx2 / .dds)"}
    out["map_irradiance"] = doc["irradiance"]
    out["map_radiance"] = doc["radiance"]
    return out
