import pytest

from .export_helpers import spot_cube, write_envmap, write_object


@pytest.fixture(scope="session")
def tiny_run(tmp_path_factory):
    """A run folder: envmap/ of the 32² spot map, visibility/ with one octahedron."""
    root = tmp_path_factory.mktemp("run")
    cube = spot_cube(32)
    pyr = write_envmap(root, cube)
    obj = write_object(root)
    return {"dir": root, "cube": cube, "pyramid": pyr, "object": obj}
