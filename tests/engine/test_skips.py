"""Each skip is bounded: the output with the skip against the output without it."""

import time

import numpy as np
import pytest

from engine.fd.instrument import prepare
from engine.options import RenderOptions
from engine.scene import Scene
from engine.testing.measure import held_steps, kc_skip_pitch_shift, quiet_share
from engine.testing.scenes import fret, pluck, scene


# The exact comparisons below take every skip of contact work on one side (quiet steps, the
# unreachable-fret skip and held steps; ``skip_contacts=False`` turns them all off) and none on
# the other: the runs call the general path's compiled pass and are compiled like it
# (``engine.config.JIT_STEP``), so not one sample may differ.
def _render(sc, **opts):
    eng = prepare(Scene.model_validate(sc), RenderOptions(**opts))
    t = time.perf_counter()
    out = np.concatenate(list(eng.blocks()))
    return out, eng, time.perf_counter() - t


def test_silent_strings_are_not_simulated_and_contribute_exactly_zero():
    sc = scene([pluck(1, force=2.0)], duration=0.2)
    with_skip, eng, _ = _render(sc)
    without, eng_all, _ = _render(sc, skip_silent=False)
    assert len(eng.voices) == 1 and len(eng_all.voices) == 6
    assert np.array_equal(with_skip, without)


def test_unreachable_frets_are_skipped_exactly():
    """The rigid frets are looked at only when one is within reach, and quiet and held steps run
    in their own loops: bit-identical."""
    sc = scene([pluck(6, force=20.0, duration=1e-4), pluck(1, force=20.0, duration=1e-4),
                fret(3, 2), pluck(3, time=0.02, force=10.0)], duration=0.3)
    a, eng, _ = _render(sc, kc_tolerance=0.0)
    b, _, _ = _render(sc, skip_contacts=False, kc_tolerance=0.0)
    quiet = sum(int(v.state.run_steps[0]) for v in eng.voices)
    held, _ = held_steps(eng)
    assert quiet > 0 and held > 0, (quiet, held)  # both runs took part
    assert np.array_equal(a, b)


def _ev(kind, time, string, **kw):
    return {"type": kind, "time": time, "string": string, **kw}


FAST = {  # everything that moves a string fast, at the top of the allowed ranges (draft: 1x)
    "5 m/s taps, 10 N": [_ev("tap", 0.005 * (s - 1), s, fret=5, force=10.0, velocity=5.0)
                         for s in range(1, 7)],
    "hammer-on on a plucked note": [fret(2, 2, force=10.0), pluck(2, time=0.002, force=5.0),
                                    _ev("hammer_on", 0.01, 2, fret=9, force=10.0, velocity=5.0)],
    "10 N finger lifted near the nut": [fret(1, 1, force=10.0, release=0.02)],
    "slide over 19 frets in 1 ms": [_ev("slide", 0.0, 2, from_fret=1, to_fret=20, duration=1e-3,
                                        force=10.0)],
    "pull-off 20 N": [fret(3, 7, force=10.0), _ev("pull_off", 0.01, 3, fret=7, force=20.0)],
    "pop 20 N": [pluck(4, force=20.0, style="pop")],
    "3-semitone bend in one step": [fret(3, 3, force=10.0), pluck(3, time=0.002, force=5.0),
                                    _ev("bend", 0.01, 3, semitones=3.0, duration=1e-5,
                                        release=0.02)],
}


@pytest.mark.parametrize("case", sorted(FAST))
def test_unreachable_frets_are_skipped_exactly_when_the_string_moves_fast(case):
    """string.fret_margin bounds the speed of every node from the plucks and fingers of the
    scene; the skip must not change a sample."""
    sc = {**scene(FAST[case], duration=0.05), "quality": "draft"}
    a, _, _ = _render(sc, kc_tolerance=0.0)
    b, _, _ = _render(sc, skip_contacts=False, kc_tolerance=0.0)
    assert np.array_equal(a, b)


def test_unreachable_frets_are_skipped_exactly_on_a_light_string_under_a_finger():
    """A light, slack string (radius 50 um: Z = sqrt(T rho A) ~ 5e-4 kg/s) under two fingers
    pressing with 3 N is thrown around the frets far faster than the fingers move (found by the
    random stress test: the skipped frets were crossed and their reactions added energy)."""
    sc = {"duration": 0.025, "sample_rate": 22050, "quality": "draft",
          "output": {"body": "none", "normalize": False},
          "guitar": {"strings": [{"string": 6, "radius_m": 5e-05, "density_kg_m3": 573.0,
                                  "t60_fundamental_s": 0.237, "t60_2khz_s": 2.89}]},
          "events": [_ev("hammer_on", 0.005, 6, fret=13, velocity=0.0124),
                     _ev("tap", 0.016, 6, fret=15, velocity=0.0112)]}
    a, _, _ = _render(sc, kc_tolerance=0.0)
    b, _, _ = _render(sc, skip_contacts=False, kc_tolerance=0.0)
    assert np.array_equal(a, b)


def test_decayed_strings_stop_with_a_bounded_difference():
    """A short note in a long scene: the string stops once every node moves slower than
    1e-7 m/s; the output differs by less than 1e-6 m/s (-128 dB of the fixed gain's full scale)."""
    sc = scene([fret(1, 5, force=3.0), pluck(1, time=0.0, force=2.0),
                {"type": "fret", "time": 0.5, "string": 1, "fret": 0}], duration=12.0)
    sc["guitar"] = {"strings": [{"string": 1, "t60_fundamental_s": 0.5, "t60_2khz_s": 0.2}]}
    a, eng, t_skip = _render(sc)
    b, _, t_full = _render(sc, skip_decayed=False)
    assert eng.voices[0].stopped
    peak = np.abs(b).max()
    assert peak > 1e-2
    assert np.abs(a - b).max() < 1e-6
    assert t_skip < t_full


@pytest.mark.parametrize("force", [2.0, 8.0])
def test_quiet_steps_are_most_steps_of_an_open_strum(force):
    """Nothing but the string acts after the pluck, and no contact happens: at least 90 % of each
    string's steps in the first second take the quiet run.  (An 8 N pluck keeps the thin strings
    within the unreachable-fret margin of the fret tips; their steps are quiet because the quiet
    run checks the frets exactly.  ``benchmarks/skips.py`` prints the shares over 2 s.)"""
    share = quiet_share(force, seconds=1.0)
    assert min(share.values()) > 0.9, share


@pytest.mark.parametrize("string", [1, 6])
def test_without_fretboard_and_frets_every_step_after_the_pluck_is_quiet(string):
    """``benchmarks.speed``'s linear string (no Kirchhoff-Carrier, fretboard or frets): nothing can
    touch the string, so every step after the pluck's force is quiet: the nodes an 8 N pluck
    drives below where a board would be must not send steps to the general path, or the linear
    string the speed targets divide by takes longer."""
    sc = scene([pluck(string, force=8.0)], duration=0.5)
    opts = {"kirchhoff_carrier": False, "fretboard": False, "frets": False, "skip_decayed": False}
    _, eng, _ = _render(sc, **opts)
    v = eng.voices[0]
    forced = int(v.ctl.arrays.pl_start[0] + v.ctl.arrays.pl_len[0]) + 2  # (+ the step after)
    assert int(v.state.run_steps[0]) >= v.step - forced, (v.state.run_steps, v.step, forced)


def test_without_fretboard_and_frets_the_pass_counts_nothing_and_the_runs_stay_exact():
    """Such a string's linear pass leaves out the counts of nodes near a contact
    (``kernels._counted``), in every loop alike: quiet and held steps are bit-identical to the
    general path."""
    sc = scene([pluck(1, force=8.0), fret(3, 5), pluck(3, time=0.01, force=8.0)], duration=0.2)
    opts = {"fretboard": False, "frets": False, "kc_tolerance": 0.0}
    a, eng, _ = _render(sc, **opts)
    b, _, _ = _render(sc, skip_contacts=False, **opts)
    assert all(v.coefs.board_k == 0.0 and len(v.geom.fret_p) == 0 for v in eng.voices)
    quiet = sum(int(v.state.run_steps[0]) for v in eng.voices)
    held, _ = held_steps(eng)
    assert quiet > 0 and held > 0, (quiet, held)
    assert np.array_equal(a, b)


def test_quiet_steps_are_exact_in_a_strum_with_articulations():
    sc = scene([pluck(6 - i, time=0.02 * i, force=2.0) for i in range(6)]
               + [fret(2, 3, time=0.3), pluck(2, time=0.32, force=1.0),
                  {"type": "bend", "time": 0.4, "string": 3, "semitones": 1.0, "duration": 0.05},
                  {"type": "mute", "time": 0.6, "string": 5, "amount": 0.5},
                  {"type": "harmonic", "time": 0.5, "string": 4, "fret": 12, "release": 0.55},
                  pluck(4, time=0.5, force=1.0)], duration=0.8)
    a, _, _ = _render(sc, kc_tolerance=0.0)
    b, _, _ = _render(sc, skip_contacts=False, kc_tolerance=0.0)
    assert np.array_equal(a, b)


@pytest.mark.parametrize("string", range(1, 7))
def test_kirchhoff_carrier_skip_moves_the_pitch_less_than_its_tolerance(string):
    """Quiet steps leave Kirchhoff-Carrier out while its tension rise is below 1e-4 T (the
    ``standard`` level): the pitch it then adds, about 866 x 1e-4 = 0.087 cents, is the bound.
    Measured on a 2 N pluck (``engine.testing.measure.kc_skip_pitch_shift``; ``benchmarks/skips.py``
    prints the table)."""
    shift, acted = kc_skip_pitch_shift(string, 2.0)
    assert acted  # the skip changed the render, so the bound below was tested
    assert abs(shift) < 866 * 1e-4
