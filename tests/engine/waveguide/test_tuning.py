"""The waveguide's strings are in tune: open strings on their nominal pitch, stopped strings on
12-TET, partials stretched as a stiff string's, and decays as the presets' T60 values say."""

import math

import numpy as np
import pytest

import engine
from engine import waveguide
from engine.analysis import cents, partials
from engine.models import PRESSED_STRING
from engine.waveguide import WaveguideOptions
from engine.waveguide.fingering import stopped_frequency
from engine.waveguide.string import physical

from .conftest import SR, fret, pitch_cents, pluck, render, scene

PRESET_NAMES = ["steel-acoustic", "nylon-classical", "electric", "bass"]


@pytest.mark.parametrize("name", PRESET_NAMES)
def test_open_strings_within_one_cent(presets, name):
    p = presets[name]
    errors = {}
    for s in range(1, p.n_strings + 1):
        a = render([pluck(s)], 1.2, guitar={"preset": name})
        errors[s] = round(pitch_cents(a, p.strings[s - 1].frequency_hz, 0.1), 3)
    assert max(abs(e) for e in errors.values()) <= 1.0, errors


@pytest.mark.parametrize("name", PRESET_NAMES)
def test_fretted_notes_frets_1_to_12_within_3_cents(presets, name):
    """A finger pressing behind frets 1-12 on every string (3 N, or the preset's press where the
    string needs more to rest on the fret), plucked: 12-TET within +-3 cents.  The default
    intonation is ideal (the stopped loop is tuned to the fret's pitch), so this checks the
    loop, its termination filters, the fret collisions next to the stop and the glide."""
    p = presets[name]
    errors = {}
    for s in range(1, p.n_strings + 1):
        for q in range(1, 13):
            force = 3.0 if name == "steel-acoustic" else None
            a = render([fret(s, q, force=force), pluck(s, time=0.05)], 1.2,
                       guitar={"preset": name})
            target = p.strings[s - 1].frequency_hz * 2 ** (q / 12)
            errors[(s, q)] = round(pitch_cents(a, target), 2)
    assert max(abs(e) for e in errors.values()) <= 3.0, errors


@pytest.mark.parametrize("string,q", [(1, 5), (2, 12), (4, 7), (6, 3)])
def test_physical_intonation_sounds_its_model(presets, string, q):
    """With intonation "physical" the stopped string sounds the pitch of the intonation model
    (speaking length with the setback, pressing stretch, stiffness over the crown)."""
    p = presets["steel-acoustic"]
    a = render([fret(string, q), pluck(string, time=0.05)], 1.2,
               WaveguideOptions(intonation="physical"))
    phys = physical(p, string)
    f = stopped_frequency(p, phys, string, float(p.fret_x_m(q, p.strings[string - 1])), q,
                          "physical", p.finger.press_force_n)
    assert abs(pitch_cents(a, f)) <= 0.5


@pytest.mark.parametrize("string,q", [(1, 5), (6, 12)])
def test_physical_intonation_nut_compensation_flattens_fretted_notes(presets, string, q):
    """The nut moved n towards the frets leaves the frets where the scale puts them: the open
    string, tuned to its pitch over L - n, loses tension, so a fretted note (same speaking length)
    sounds 1200 log2((L - n) / L) cents flatter than with n = 0 (the flexible string; pressing
    and stiffness move it by less than 0.1 cent).  Frets placed from an uncompensated nut
    shorten the speaking length by n as well and sound sharp of that instead."""
    p = presets["steel-acoustic"]
    spec = p.strings[string - 1]
    target = spec.frequency_hz * 2 ** (q / 12)
    opts = WaveguideOptions(intonation="physical", finger_damping=False)
    n = 0.005
    heard = []
    for nut in (0.0, n):
        guitar = {"preset": "steel-acoustic",
                  "strings": [{"string": string, "nut_compensation_m": nut}]}
        a = render([fret(string, q), pluck(string, time=0.05)], 1.2, opts, guitar=guitar)
        heard.append(pitch_cents(a, target))
    length = p.scale_length_m + spec.saddle_setback_m
    expected = 1200 * math.log2((length - n) / length)
    assert abs((heard[1] - heard[0]) - expected) <= 0.3, (heard, expected)


@pytest.mark.parametrize("string", [1, 2, 5, 6])
def test_partials_follow_the_stiff_string(presets, string):
    """Partials 2-10 of a soft pluck within 0.3 cents of f_n = n f1 sqrt(1 + B n^2) /
    sqrt(1 + B) (the dispersion filter); without the filter the 10th is harmonic, more than 0.7
    cents flat of it on every one of these strings."""
    p = presets["steel-acoustic"]
    phys = physical(p, string)
    b = phys.inharmonicity(phys.length_m)
    f1 = phys.f0
    n = np.arange(1, 11)
    target = n * f1 * np.sqrt(1 + b * n * n) / math.sqrt(1 + b)

    def errors(options=None):
        a = render([pluck(string, force=0.2, position=0.87)], 1.5, options)
        return cents(partials(a[int(0.1 * SR):], SR, f1, 10, b), target)

    err = errors()
    assert np.max(np.abs(err[1:])) <= 0.3, np.round(err, 2)
    assert errors(WaveguideOptions(dispersion=False))[-1] < -0.7


@pytest.mark.parametrize("string", [1, 6])
def test_the_loops_phase_gives_the_partials_it_sounds(presets, string):
    """``WaveguideVoice.partial_frequencies`` (the loop's phase relation, which the accuracy study
    quotes as the waveguide's exact partials) against partials 1-10 measured on a soft pluck:
    within 0.02 cents, while the dispersion filter itself moves the 10th by more than 0.7."""
    sc = engine.parse_scene({**scene([pluck(string, force=0.2, position=0.87)], 1.5),
                             "model": "waveguide"})
    inst = waveguide.prepare(sc, statics=PRESSED_STRING)
    voice = inst.voices[0]
    exact = voice.partial_frequencies(10)
    a = np.concatenate(list(inst.blocks()))
    b = voice.phys.inharmonicity(voice.phys.length_m)
    measured = partials(a[int(0.1 * SR):], SR, voice.phys.f0, 10, b)
    assert np.max(np.abs(cents(measured, exact))) <= 0.02, np.round(cents(measured, exact), 4)
    flat = waveguide.prepare(sc, WaveguideOptions(dispersion=False),
                             statics=PRESSED_STRING).voices[0]
    assert cents(exact[-1], flat.partial_frequencies(10)[-1]) > 0.7


def _decay_db_s(audio: np.ndarray, f: float, t0: float, t1: float) -> float:
    n = int(0.1 * SR)
    w = np.hanning(n)
    tone = np.exp(-2j * np.pi * f * np.arange(n) / SR)
    times = np.arange(t0, t1 - 0.1, 0.05)
    lv = [20 * np.log10(abs(np.sum(audio[int(t * SR):int(t * SR) + n] * w * tone)))
          for t in times]
    return float(np.polyfit(times, lv, 1)[0])


@pytest.mark.parametrize("string", [1, 4, 6])
def test_fundamental_decays_at_the_presets_t60(presets, string):
    """The loss filter is fitted to the preset's T60 at the fundamental: -60 dB in T60 seconds
    (within 10 %), on a soft pluck (no fret contact, little glide)."""
    p = presets["steel-acoustic"]
    spec = p.strings[string - 1]
    a = render([pluck(string, force=0.1)], 3.0)
    rate = _decay_db_s(a, spec.frequency_hz, 0.3, 2.9)
    assert rate == pytest.approx(-60.0 / spec.t60_fundamental_s, rel=0.1)


def test_bend_and_vibrato_reach_their_pitch(presets):
    p = presets["steel-acoustic"]
    f = p.strings[1].frequency_hz
    a = render([pluck(2, force=1.0), {"type": "bend", "time": 0.2, "string": 2,
                                      "semitones": 2.0, "duration": 0.15}], 1.2)
    assert abs(pitch_cents(a, f * 2 ** (2 / 12), 0.5, 1.1)) <= 1.0
    a = render([pluck(2, force=1.0), {"type": "bend", "time": 0.1, "string": 2, "semitones": 1.0,
                                      "duration": 0.1, "release": 0.4}], 1.4)
    assert abs(pitch_cents(a, f * 2 ** (1 / 12), 0.2, 0.4)) <= 2.0
    assert abs(pitch_cents(a, f, 0.7, 1.4)) <= 1.0


def test_a_hard_pluck_glides_down(presets):
    """Tension modulation: an 8 N pluck starts sharp and settles (string 2, no fret contacts, so
    that the glide is the tension's alone); a 0.2 N one barely moves; no glide without it."""
    p = presets["steel-acoustic"]
    f = p.strings[1].frequency_hz
    no_contacts = WaveguideOptions(collisions=False)

    def glide(force, options):
        a = render([pluck(2, force=force)], 1.0, options)
        return pitch_cents(a, f, 0.01, 0.11) - pitch_cents(a, f, 0.5, 0.6)

    assert glide(8.0, no_contacts) > 5.0
    assert abs(glide(0.2, no_contacts)) < 0.5
    assert abs(glide(8.0, WaveguideOptions(collisions=False, glide=False))) < 0.5


@pytest.mark.parametrize("string", [1, 2])
def test_a_hard_slap_glides_as_the_finite_difference_string_does(presets, string):
    """A 20 N slap: the glide reads the string's elongation, not the dent the slap's contact
    leaves at its point while what it put on the string leaks away (``pluck``), a one-point
    spike whose slope the grid cannot resolve.  Read with the dent, the glide put the first
    20 ms hundreds of cents sharp where the finite-difference string, at ``standard``, glides by
    about ten; here the two stay within 20 cents of each other."""
    f = presets["steel-acoustic"].strings[string - 1].frequency_hz
    events = [pluck(string, force=20.0, style="slap")]
    wg = render(events, 0.3)
    fd = engine.render({**scene(events, 0.3), "output": {"body": "none", "normalize": False}})
    # 5-25 ms, the peak searched within half the frequency either way (a glide can be large)
    c_wg, c_fd = (pitch_cents(a, f, 0.005, 0.025, rel_width=0.5) for a in (wg, fd))
    print(f"string {string}: waveguide {c_wg:+.1f} cents, finite difference {c_fd:+.1f}")
    assert abs(c_wg - c_fd) < 20.0


def test_engine_public_names_unchanged():
    assert engine.parse_scene({"duration": 1.0}).model == "fdtd"
    assert engine.parse_scene({"duration": 1.0, "model": "waveguide"}).model == "waveguide"
