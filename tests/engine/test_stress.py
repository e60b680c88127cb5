"""Stability stress test (issue #4): random valid scenes, stored energy bounded by the work done,
and the auxiliary variables of the DAFx24 paper's sec. 4.7.

The checks (``engine.testing.stability``) and the random scenes (``engine.testing.random_scenes``)
are shared with the long soak ``benchmarks/soak.py`` (minutes, 60-second scenes, thousands of
cases; its summary is in docs/accuracy.md).  This file is the short CI run.

The reproducers at the end are the engine defects the stress test and the soak found
(docs/accuracy.md, "Defects found"), kept as regression tests now that they are fixed.  The random
test renders every valid scene it draws with the default options (every skip on), as the soak does;
inputs the engine cannot render are rejected by validation (``engine.scene``).
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import HealthCheck, assume, given, settings
from pydantic import ValidationError

import engine
from engine.fd.instrument import prepare
from engine.options import RenderOptions
from engine.scene import MAX_FINGER_FORCE_N, MAX_PLUCK_FORCE_N, MAX_TAP_VELOCITY_M_S, Scene
from engine.testing.measure import board_depth
from engine.testing.random_scenes import scenes
from engine.testing.scenes import fret, pluck, scene, tap
from engine.testing.stability import LIMITS, QUIET_S, PsiProbe, check, violations


# derandomize: CI must be reproducible; the soak (benchmarks/soak.py) explores new cases
@settings(max_examples=100, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
@pytest.mark.slow  # a soak of random scenes or a long render; CI runs it
@given(sc=scenes(max_duration=0.15, max_events=12, qualities=("draft", "draft", "standard")))
def test_random_valid_scenes_are_stable(sc):
    """Any preset, any event type, extremes of every range, any sample rate: finite output, the
    energy balance, stored energy never above the initial energy plus the work done on the
    strings, and no step that creates energy."""
    try:
        Scene.model_validate(sc)
    except ValidationError:
        assume(False)
    rep = check(sc)
    assert not rep.error and rep.finite, rep.error
    assert rep.balance <= LIMITS["balance"]
    assert rep.excess <= LIMITS["excess"]
    assert rep.q_min >= LIMITS["q_min"]


@pytest.mark.parametrize("rate", [22050, 32000, 44100, 48000, 88200, 96000])
def test_every_sample_rate_at_the_top_of_the_force_ranges(rate):
    evs = []
    for s in range(1, 7):
        evs += [fret(s, 1 + 2 * s, force=MAX_FINGER_FORCE_N),
                pluck(s, time=0.01, force=MAX_PLUCK_FORCE_N, duration=1e-4, position=0.98),
                pluck(s, time=0.03, force=MAX_PLUCK_FORCE_N, style=("slap", "pop", "pick")[s % 3]),
                {"type": "bend", "time": 0.04, "string": s, "semitones": 3.0, "duration": 0.02},
                tap(s, 12, time=0.06, force=MAX_FINGER_FORCE_N, velocity=MAX_TAP_VELOCITY_M_S)]
    rep = check(scene(evs, duration=0.1, sample_rate=rate, guitar={"preset": "electric"}))
    assert violations(rep) == []


def _psi_trace(sc: dict, **options):
    eng = prepare(Scene.model_validate({**sc, "diagnostics": True}),
                  RenderOptions(energy_series=True, **options))
    probe = PsiProbe(eng.voices)
    for _ in eng.blocks(16):
        probe()
    return eng, probe


@pytest.mark.parametrize("preset", ["steel-acoustic", "electric"])
def test_fretboard_psi_returns_to_zero_after_contact(preset):
    """Sec. 4.7, on the Hertzian fretboard (a SAV column): out of contact the gamma rule drives
    psi_B to zero, so no energy stays in a fretboard that nothing touches.  (A 20 N pluck at
    0.7 L swings the low E onto the board; at 0.65 L the electric's, 0.6 mm longer than its
    scale, misses it.)"""
    sc = scene([pluck(6, force=MAX_PLUCK_FORCE_N, position=0.7)], duration=0.2,
               guitar={"preset": preset})
    eng, probe = _psi_trace(sc, rigid_board=False)
    v = eng.voices[0]
    samples = probe.samples[6, "board"]
    assert max(abs(p) for _, _, p in samples) > 0.0, "the string never reached the fretboard"
    board, _ = probe.residuals(6, v.coefs.k, QUIET_S)
    assert board, "no contact-free stretch after a contact"
    assert max(board) / float(np.max(np.concatenate(v.energy_h))) <= LIMITS["board_residual"]


def test_finger_psi_returns_to_zero_after_the_finger_bounces_off():
    """The finger drop of paper Fig. 2 with no pressing force: the finger strikes the string and
    leaves it; its psi goes back to zero."""
    sc = scene([tap(4, 5, force=1e-6, velocity=0.7)], duration=0.3)
    eng, probe = _psi_trace(sc)
    v = eng.voices[0]
    samples = probe.samples[4, 0]
    assert any(c for _, c, _ in samples) and not samples[-1][1]
    _, finger = probe.residuals(4, v.coefs.k, QUIET_S)
    assert finger and max(finger) / float(np.max(np.concatenate(v.energy_h))) <= 1e-9


# ---- reproducers of defects (see the module docstring) ------------------------------------------


@pytest.mark.parametrize("oversample", [2, 4, 8])
def test_fretboard_stops_a_string_tapped_hard(oversample):
    """The gamma rule of sec. 4.7 decided on the board's own prediction dropped the board's force
    while the finger drove the string into it (a 1 m/s tap sank it 131 um at x4).  With the joint
    rule the string sinks into the Hertzian board no deeper than 1.5x the static penetration of
    the whole finger force resting on one grid cell, (F / (K_B h))^(1/alpha)."""
    deepest, static = board_depth(1.0, oversample, force=MAX_FINGER_FORCE_N, rigid_board=False)
    assert deepest < 1.5 * static


@pytest.mark.parametrize("oversample", [2, 4, 8])
def test_gamma_correction_does_not_let_the_string_sink_deeper_than_no_correction(oversample):
    """A 5 m/s slam on the Hertzian board: the contact is stiffer than the grid resolves (its
    frequency is above the internal rate), so even the uncorrected scheme (gamma = 1) lets the
    string sink hundreds of um;
    the correction must not make that worse (the per-column rule went 25-75 % deeper).  Measured
    at frets 10-14 of string 1: where the fret and the finger fall between the nodes moves each
    depth by a few per cent either way (one fret alone, at 2 % above no correction, failed when
    the frets were calibrated and would have failed at fret 10 before), so the joint rule is
    held to no deeper on average and at most 10 % deeper at any of the five."""
    ratios = [board_depth(MAX_TAP_VELOCITY_M_S, oversample, force=MAX_FINGER_FORCE_N, fret=q,
                          rigid_board=False)[0]
              / board_depth(MAX_TAP_VELOCITY_M_S, oversample, "none", force=MAX_FINGER_FORCE_N,
                            fret=q, rigid_board=False)[0] for q in range(10, 15)]
    assert np.mean(ratios) <= 1.0 and max(ratios) <= 1.1, ratios


@pytest.mark.parametrize("quality", ["draft", "standard", "high"])
def test_the_rigid_fretboard_stops_a_slam(quality):
    """The issue asked for 10 N, 5 m/s taps no deeper than 100 um into the board (the Hertzian
    board, K_B = 1e10, let them sink about 1.4 mm at ``standard``: docs/accuracy.md).  The rigid
    board's nodes join the frets' active set, so no node goes deeper than the active set's
    tolerance (1e-12 m), on a high, a middle and a low string, at fret 5 and at fret 12.  At
    fret 5 the tap drives each string onto the board (a node rests on it, within 1 nm)."""
    for string in (1, 3, 6):
        for fret_ in (5, 12):
            deepest, _ = board_depth(MAX_TAP_VELOCITY_M_S, None, force=MAX_FINGER_FORCE_N,
                                     fret=fret_, string=string, quality=quality)
            assert deepest <= 1e-12, (string, fret_, deepest)
            if fret_ == 5:
                assert deepest > -1e-9, (string, deepest)


def test_unreachable_fret_skip_is_exact_for_fast_taps():
    """``string.fret_margin`` bounded the string's speed by the plucks only; a 5 m/s tap moved it
    further in one step, a skipped fret was crossed and its reaction then added energy."""
    sc = scene([tap(3, 5, force=MAX_FINGER_FORCE_N, velocity=MAX_TAP_VELOCITY_M_S)],
               duration=0.1, quality="draft")
    # held steps in the general path, as in test_skips.py's exact comparisons
    a = engine.render(sc, options=RenderOptions(kc_tolerance=0.0, held_steps=False))
    b = engine.render(sc, options=RenderOptions(skip_contacts=False, kc_tolerance=0.0))
    assert np.array_equal(a, b)


def test_finger_psi_returns_to_zero_when_another_finger_takes_its_place():
    """Two fingers on the same nodes: each one's gamma is decided on the joint solution."""
    sc = {**scene([{"type": "hammer_on", "time": 0.0, "string": 4, "fret": 13, "force": 7.4,
                    "velocity": 0.01}, fret(4, 13, time=0.034, force=10.0)], duration=0.1,
                  sample_rate=48000, guitar={"preset": "nylon-classical"})}
    assert violations(check(sc)) == []


PENDING = {  # valid inputs the engine could not render; each is now rendered or rejected
    "pitch too high for the rate": scene(
        [pluck(1)], duration=0.05, sample_rate=22050,
        guitar={"strings": [{"string": 1, "note": "C6"}]}),
    "bending stiffness above the pitch": scene(
        [pluck(1)], duration=0.05,
        guitar={"strings": [{"string": 1, "note": "C#1", "radius_m": 2e-3, "density_kg_m3": 500.0,
                             "youngs_modulus_pa": 4e11}]}),
    "tune runs out of retries": scene(
        [pluck(1)], duration=0.05,
        guitar={"strings": [{"string": 1, "note": "C#1", "radius_m": 5e-5, "density_kg_m3": 500.0,
                             "youngs_modulus_pa": 1e8, "t60_fundamental_s": 0.05,
                             "t60_2khz_s": 0.02}]}),
    "strings below the fret tips": scene(
        [pluck(5, force=20.0, style="slap")], duration=0.1,
        guitar={"action_nut_m": 3e-3, "action_12th_m": 3e-4}),
}


@pytest.mark.parametrize("case", sorted(PENDING))
def test_valid_scenes_render_or_are_rejected_by_validation(case):
    try:
        Scene.model_validate(PENDING[case])
    except ValidationError:
        return  # rejected at the edge with a message: fine
    assert violations(check(PENDING[case])) == []
