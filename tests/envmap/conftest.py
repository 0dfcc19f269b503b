import pytest

from .envmap_helpers import sky_sun_cube


@pytest.fixture(scope="session")
def sky_sun_32():
    return sky_sun_cube(32)
