import pytest

from engine.presets import get_preset


@pytest.fixture(scope="session")
def steel():
    return get_preset("steel-acoustic")
