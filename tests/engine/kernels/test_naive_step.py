"""The compiled step against the plain-NumPy reference of one complete time step
(``engine.testing.naive_step``): the same state in, the state out within 1e-12 of its scale, on
scenes that between them bring every column and contact into play, step by step over the stretch
where they act."""

from dataclasses import replace

import pytest

from engine import QUALITY, RenderOptions
from engine.testing.naive_step import CASES, compare_steps
from engine.testing.scenes import fret, pluck, scene

TOL = 1e-12


@pytest.mark.parametrize("name", sorted(CASES))
def test_step_matches_the_naive_reference(name):
    events, seconds, kinds = CASES[name]
    r = compare_steps(scene(events, seconds), seconds)
    assert r["steps"] > 100
    assert kinds <= set(r["kinds"]), r["kinds"]  # the columns the case is for did act
    assert r["decisions"] == 0, r
    for field, err in r["worst"].items():
        assert err <= TOL, (field, r)


def test_penalty_frets_match_the_naive_reference():
    q = replace(QUALITY["standard"], fret_mode="penalty", calibrate_frets=False)
    r = compare_steps(scene([fret(3, 5), pluck(3, time=0.002, force=4.0)], 0.006), 0.006,
                      RenderOptions(quality=q))
    assert r["kinds"].get("sav", 0) > 100, r["kinds"]
    assert r["decisions"] == 0, r
    for field, err in r["worst"].items():
        assert err <= TOL, (field, r)


def test_the_hertzian_fretboard_matches_the_naive_reference():
    """The slam of ``CASES`` on the fretboard of eq. (7) (the SAV column), not the rigid one."""
    events, seconds, _ = CASES["slam"]
    r = compare_steps(scene(events, seconds), seconds, RenderOptions(rigid_board=False))
    assert r["kinds"].get("sav", 0) > 10 and "rigid board" not in r["kinds"], r["kinds"]
    assert r["decisions"] == 0, r
    for field, err in r["worst"].items():
        assert err <= TOL, (field, r)


def test_a_landed_fingers_calibrated_damping_matches_the_naive_reference():
    """String 4 at fret 10: the finger lands with the preset's damping and holds with the one
    calibrated for that fret (``intonation.finger_damping``, several times the preset's there)
    from 10 ms on, inside the stretch compared."""
    from engine import Scene
    from engine.fd.instrument import prepare
    from engine.testing.scenes import SR

    sc = scene([fret(4, 10), pluck(4, time=0.008, force=4.0)], 0.014)
    v = prepare(Scene.model_validate(sc)).voices[0]
    ctl = v.ctl.arrays
    assert ctl.fs_r[0] > 2.0 * v.coefs.fg_r
    assert 0 < ctl.fs_rs[0] < 0.014 * SR * v.oversample
    r = compare_steps(sc, 0.014)
    assert r["decisions"] == 0, r
    for field, err in r["worst"].items():
        assert err <= TOL, (field, r)
