import pytest

from engine.presets import get_preset
from engine.testing.scenes import SR, fret, pluck, scene, tap  # noqa: F401  (the one set of builders)


@pytest.fixture(scope="session")
def steel():
    return get_preset("steel-acoustic")
