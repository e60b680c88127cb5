import pytest

from benchmarks.scenes import SR, fret, pluck, scene, tap  # noqa: F401  (the tests' builders)
from engine.presets import get_preset


@pytest.fixture(scope="session")
def steel():
    return get_preset("steel-acoustic")
