"""The finite-difference model's articulation measurements (``engine.testing.articulations``,
asserted in tests/engine/test_articulations.py) run on the waveguide, with the same limits.  The
energy balance of those tests has no counterpart here (``WaveguideInstrument.energy_error`` is 0.0;
tests/engine/waveguide/test_passivity.py checks the waveguide's passivity instead)."""

import pytest

from engine.testing import articulations as art
from engine.testing import scenes

LIMIT_CENTS = 10.0


@pytest.fixture(autouse=True)
def waveguide(monkeypatch):
    def scene(events, duration=1.0, **extra):
        return {**scenes.scene(events, duration, **extra), "model": "waveguide"}

    monkeypatch.setattr(art, "scene", scene)


def test_bend_holds_and_returns():
    assert abs(art.bend()["held"]) <= LIMIT_CENTS
    m = art.bend_release()
    assert abs(m["held"]) <= LIMIT_CENTS and abs(m["released"]) <= LIMIT_CENTS


def test_vibrato_rate_and_depth():
    m = art.vibrato()
    assert m["rate_hz"] == pytest.approx(m["asked_rate_hz"], rel=0.05)
    assert m["depth_cents"] == pytest.approx(m["asked_depth_cents"], rel=0.2)


def test_slide_hammer_on_pull_off():
    s, h, p = art.slide(), art.hammer_on(), art.pull_off()
    assert abs(s["before"]) <= LIMIT_CENTS and abs(s["after"]) <= LIMIT_CENTS
    assert abs(h["after"]) <= LIMIT_CENTS
    assert abs(p["before"]) <= LIMIT_CENTS and abs(p["after"]) <= LIMIT_CENTS


@pytest.mark.parametrize("q,partial", [(12, 2), (7, 3)])
def test_natural_harmonics(q, partial):
    m = art.harmonic(q)
    assert m["loudest"] == partial, m["levels"]
    if q == 12:
        assert m["levels"][1] <= m["levels"][2] - 20.0, m["levels"]


def test_palm_mute_and_dead_note():
    assert art.palm_mute()["drop_db"] >= 20.0
    assert art.dead_note()["drop_db"] >= 20.0
