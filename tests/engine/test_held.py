"""Held steps of a fretted note (``kernels._held_run``) against the general path.

A held step is the general path's step for a finger pressing the string onto its frets, in a loop
of its own.  Both loops are compiled without fastmath and call the same compiled linear pass
(``engine.config.JIT_STEP``), so the two must agree bit for bit (``tools/held_soak.py`` runs
the stability soak's random scenes both ways).
"""

import numpy as np
import pytest

from engine.fd.instrument import prepare
from engine.options import RenderOptions
from engine.scene import Scene
from engine.testing.measure import held_steps
from engine.testing.scenes import fret, pluck, scene, tap


def _ev(kind, time, string, **kw):
    return {"type": kind, "time": time, "string": string, **kw}


CHORD = [fret(6, 3), fret(5, 2), fret(2, 1)] + [pluck(6 - i, time=0.02 + 0.02 * i, force=2.0)
                                                for i in range(6)]
# (scene, RenderOptions keywords): every way a finger holds a string that the held run takes, and
# the ways it stops holding (a slide, a second finger, a lifted finger, a bend, a hard pluck)
CASES = {
    "fretted chord": (scene(CHORD, duration=0.3), {}),
    "chord at draft": ({**scene(CHORD, duration=0.3), "quality": "draft"}, {}),
    "8 N pluck, no Kirchhoff-Carrier": (scene([fret(4, 5), pluck(4, time=0.01, force=8.0)],
                                              duration=0.3), {"kirchhoff_carrier": False}),
    "articulations": (scene([
        fret(3, 5), pluck(3, time=0.01, force=4.0),
        _ev("slide", 0.1, 3, from_fret=5, to_fret=7, duration=0.05),
        _ev("bend", 0.2, 3, semitones=1.0, duration=0.05),
        fret(2, 5), pluck(2, time=0.01, force=3.0), _ev("hammer_on", 0.1, 2, fret=7),
        _ev("pull_off", 0.2, 2, fret=7),
        tap(1, 12, time=0.05, force=3.0),
        fret(4, 2, release=0.2), pluck(4, time=0.01, force=2.0),
        _ev("vibrato", 0.1, 4, rate_hz=6.0, depth_cents=40.0, duration=0.08),
    ], duration=0.3), {}),
    "10 N, 20 N pluck at fret 12": (scene([fret(1, 12, force=10.0),
                                          pluck(1, time=0.01, force=20.0)], duration=0.2), {}),
}


def _render(name, held):
    sc, opts = CASES[name]
    eng = prepare(Scene.model_validate(sc), RenderOptions(held_steps=held, **opts))
    out = np.concatenate(list(eng.blocks()))
    return out, *held_steps(eng)


def compare() -> dict:
    """Per case: [bit-identical, largest difference / peak, held steps, all steps]."""
    res = {}
    for name in CASES:
        a, held, steps = _render(name, True)
        b, none, _ = _render(name, False)
        assert none == 0
        res[name] = [bool(np.array_equal(a, b)), float(np.max(np.abs(a - b)) / np.max(np.abs(b))),
                     held, steps]
    return res


@pytest.fixture(scope="module")
def compared():
    return compare()


@pytest.mark.parametrize("name", sorted(CASES))
def test_held_steps_are_the_general_paths_arithmetic(compared, name):
    """The same samples with held steps as without, to the last bit, with the kernels' own
    flags; and the held run took most of the fingered steps, so the comparison tested it."""
    identical, diff, held, steps = compared[name]
    assert held > 0.3 * steps, (held, steps)
    assert identical, diff


def test_held_steps_are_most_steps_of_a_held_note():
    eng = prepare(Scene.model_validate(scene([fret(4, 5), pluck(4, time=0.01, force=8.0)],
                                             duration=0.5)))
    for _ in eng.blocks():
        pass
    v = eng.voices[0]
    assert v.state.run_steps[1] > 0.95 * v.step, (v.state.run_steps[1], v.step)


@pytest.mark.parametrize("name", sorted(CASES))
def test_energy_balances_through_held_steps(name):
    """Held steps book the energy terms too (``_step_energy``, shared with the general path): with
    diagnostics the held run takes the same steps, and the balance holds to 1e-11 (sec. 6.1)."""
    sc, opts = CASES[name]
    opts = {**opts, "kc_tolerance": 0.0}  # (diagnostics keep Kirchhoff-Carrier in every step)
    eng = prepare(Scene.model_validate({**sc, "diagnostics": True}), RenderOptions(**opts))
    plain = prepare(Scene.model_validate(sc), RenderOptions(**opts))
    a = np.concatenate(list(eng.blocks()))
    assert np.array_equal(a, np.concatenate(list(plain.blocks())))  # the same steps
    held, steps = held_steps(eng)
    assert held > 0.3 * steps, (held, steps)
    err = eng.energy_error()
    assert 0.0 < err <= 1e-11, err
