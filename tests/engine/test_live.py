"""engine.Session: a live session's blocks equal the offline render of the same events (the
equivalent scene, rendered on the session's grids with ``RenderOptions(live_grid=True)``), silent
strings cost nothing, and messages that cannot be played are refused naming their field."""

from __future__ import annotations

import copy

import numpy as np
import pytest

import engine
from engine import RenderOptions

BLOCK = 256

# block index -> the messages pushed before that block
PLAN = {
    2: [{"type": "fret", "string": 5, "fret": 3}, {"type": "pluck", "string": 5, "offset": 100}],
    10: [{"type": "strum", "direction": "down", "force": 1.5}],
    20: [{"type": "bend", "string": 2, "semitones": 1.0, "duration": 0.05}],
    30: [{"type": "hammer_on", "string": 3, "fret": 5, "offset": 7},
         {"type": "pluck", "string": 1, "force": 3.0}],
    45: [{"type": "release", "string": 2, "what": "bend"},
         {"type": "mute", "string": 6, "amount": 0.5}],
    60: [{"type": "pull_off", "string": 3, "fret": 5},
         {"type": "slide", "string": 4, "from_fret": 2, "to_fret": 5, "duration": 0.1}],
    70: [{"type": "release", "what": "all"}, {"type": "pluck", "string": 4}],
    80: [{"type": "tap", "string": 2, "fret": 7, "release": 0.05},
         {"type": "harmonic", "string": 1, "fret": 12, "release": 0.1},
         {"type": "pluck", "string": 1, "offset": 3}],
    85: [{"type": "mute", "amount": 0.5}],
    90: [{"type": "release", "string": 3, "what": "mute"}, {"type": "pluck", "string": 3}],
    95: [{"type": "release", "what": "mute"}],
}


def play(session: engine.Session, plan: dict, blocks: int) -> np.ndarray:
    out = []
    for b in range(blocks):
        for m in plan.get(b, []):
            session.push(m)
        out.append(session.block())
    return np.concatenate(out)


def offline(session: engine.Session, **opts) -> np.ndarray:
    return np.concatenate(list(engine.blocks(session.scene(), BLOCK,
                                             RenderOptions(live_grid=True, **opts))))


@pytest.mark.parametrize("quality", ["draft", "standard"])
def test_session_equals_the_offline_render_of_its_events(quality):
    """To the bit, with the decayed-string skip off on both sides; ``standard`` oversamples
    (factors 1-3 here), so events act ``delay`` frames after their block boundary."""
    s = engine.Session("steel-acoustic", 44100, BLOCK, quality=quality, record=True,
                       options=RenderOptions(skip_decayed=False))
    live = play(s, PLAN, 100)
    ref = offline(s, skip_decayed=False)
    assert np.max(np.abs(live)) > 0.05
    assert np.array_equal(live, ref)
    if quality == "standard":
        assert s.delay > 0


def test_session_with_the_decay_skip_equals_the_render():
    """With the default skip on, no string decays between its events here: equal to the bit."""
    s = engine.Session("steel-acoustic", 44100, BLOCK, record=True)
    live = play(s, PLAN, 100)
    assert np.array_equal(live, offline(s))


def _long_plan(harmonics: bool = False) -> dict[int, list]:
    """90 notes on string 2 (fretted, plucked, some bent, some pulled off) three blocks apart,
    and with ``harmonics`` a harmonic on string 3 every 20th note."""
    plan: dict[int, list] = {}
    for k in range(90):
        b = 2 + 3 * k
        plan[b] = [{"type": "fret", "string": 2, "fret": 1 + k % 7},
                   {"type": "pluck", "string": 2, "offset": 20, "force": 1.0 + (k % 3)}]
        if k % 10 == 0:
            plan[b].append({"type": "bend", "string": 2, "semitones": 0.5, "duration": 0.01,
                            "release": 0.02})
        if k % 15 == 7:
            plan[b].append({"type": "pull_off", "string": 2, "fret": 1 + k % 7, "offset": 200})
        if harmonics and k % 20 == 3:
            plan[b].append({"type": "harmonic", "string": 3, "fret": 12, "release": 0.05})
            plan[b].append({"type": "pluck", "string": 3})
    return plan


def test_a_long_session_prunes_and_stays_exact():
    """Past events are dropped from a string's list once it is long (plucks over, fingers gone,
    bends returned); the samples stay those of the render of every event."""
    plan = _long_plan()
    s = engine.Session("steel-acoustic", 44100, BLOCK, record=True,
                       options=RenderOptions(skip_decayed=False))
    live = play(s, plan, 2 + 3 * 90 + 10)
    assert len(s._events[2]) < 40  # pruned (the record keeps every event)
    assert np.array_equal(live, offline(s, skip_decayed=False))


def test_a_live_compilation_reads_few_events_and_not_the_geometry(monkeypatch):
    """What an event block costs the live worker's audio thread beyond a plain block is mostly
    compiling the strings it touches (``benchmarks.live_blocks``): a compilation reads every
    event on its string, so the list is pruned once it passes ``_PRUNE_AT`` (16) events, and the
    string's geometry (frets, board, pickups: ``engine.fd.string.frame``) is computed once when
    the session is prepared, only the contact margin the events set applied at each event.  The
    samples stay those of the render (``test_a_long_session_prunes_and_stays_exact``)."""
    from engine.fd import instrument as fd_instrument
    from engine.fd import string as fd_string

    s = engine.Session("steel-acoustic", 44100, BLOCK)
    read, frames = [], []
    controls = fd_instrument.string_controls
    monkeypatch.setattr(fd_instrument, "string_controls",
                        lambda events, *a: read.append(len(events)) or controls(events, *a))
    for module in (fd_string, fd_instrument):
        for name in ("frame", "geometry"):
            if hasattr(module, name):
                f = getattr(module, name)
                monkeypatch.setattr(module, name,
                                    lambda *a, f=f, name=name, **k: frames.append(name) or f(*a, **k))
    play(s, _long_plan(), 2 + 3 * 90 + 10)
    assert len(read) >= 90
    assert max(read) <= 16 + 3  # a block's events come on top of a pruned list
    assert frames == []


def test_pruning_every_finger_away_leaves_no_finger_in_the_state():
    """Fingers put down and released, then open-string plucks until the list is pruned: every
    finger slot is dropped, and the state's finger arrays go with them (they kept the old count,
    and the decay check, which masks the controls by the state, raised an IndexError: a live
    session in benchmarks.mixed_load failed so after 161 s)."""
    s = engine.Session("steel-acoustic", 44100, BLOCK)
    plan: dict[int, list] = {}
    for k in range(8):  # eight fingers, each lifted before the next
        plan[2 + 3 * k] = [{"type": "fret", "string": 2, "fret": 3, "release": 0.01},
                           {"type": "pluck", "string": 2}]
    for k in range(70):  # open-string plucks: past _PRUNE_AT events, nothing holds a finger
        plan[40 + 2 * k] = [{"type": "pluck", "string": 2, "force": 0.3}]
    play(s, plan, 40 + 2 * 70 + 400)  # on until the string decays and is checked
    v = s.instrument.voice(2)
    assert len(v.ctl.arrays.fs_on) == 0
    assert len(v.state.f_state) == 0 and len(v.state.f_w) == 0


def test_silent_strings_cost_nothing():
    s = engine.Session("steel-acoustic", 44100, BLOCK)
    assert not np.any(s.block())
    assert s.active_strings() == []
    steps = [v.state.run_steps.sum() for v in s.voices]
    s.push({"type": "pluck", "string": 1})
    for _ in range(4):
        s.block()
    assert s.active_strings() == [1]
    assert [v.state.run_steps.sum() for v in s.voices][1:] == steps[1:]


@pytest.mark.parametrize("model", engine.MODELS)
def test_a_string_is_compiled_once_for_all_the_events_of_a_block(model, monkeypatch):
    """A fret, its pluck and a slide on one string, and a strum, in one block: each string's
    controls are compiled once (compilations are most of what an event block costs on the live
    worker's audio thread, ``benchmarks.live_blocks``), to the offline samples."""
    s = engine.Session("steel-acoustic", 44100, BLOCK, model=model, record=True,
                       options=RenderOptions(skip_decayed=False))
    compiled = []
    rebuild = s.instrument.rebuild
    monkeypatch.setattr(s.instrument, "rebuild",
                        lambda v, ev, prune: compiled.append(v.index) or rebuild(v, ev, prune))
    plan = {1: [{"type": "fret", "string": 3, "fret": 5}, {"type": "pluck", "string": 3},
                {"type": "slide", "string": 3, "from_fret": 5, "to_fret": 7, "duration": 0.1},
                {"type": "strum", "direction": "down"}]}
    live = play(s, plan, 40)
    assert sorted(compiled) == [1, 2, 3, 4, 5, 6]
    assert np.max(np.abs(live)) > 0.05
    assert np.array_equal(live, offline(s, skip_decayed=False))


def test_a_decayed_string_stops_and_plays_again():
    s = engine.Session("steel-acoustic", 44100, 1024,
                       options=RenderOptions(decay_velocity=1e-3))
    s.push({"type": "pluck", "string": 1, "force": 0.5})
    for _ in range(400):
        s.block()
        if not s.active_strings():
            break
    assert s.active_strings() == []
    s.push({"type": "pluck", "string": 1})
    assert np.max(np.abs(s.block())) > 1e-3


@pytest.mark.parametrize("message, field", [
    ({"type": "pluck", "string": 1, "time": 0.5}, "time"),
    ({"type": "strike", "string": 1}, "type"),
    ({"string": 1}, "type"),
    ({"type": "pluck", "string": 7}, "string"),
    ({"type": "pluck", "string": 1, "force": -1}, "force"),
    ({"type": "pluck", "string": 1, "offset": 256}, "offset"),
    ({"type": "pluck", "string": 1, "offset": 1.5}, "offset"),
    ({"type": "fret", "string": 1, "fret": 21}, "fret"),
    ({"type": "fret", "string": 1, "fret": 3, "release": 0}, "release"),
    ({"type": "strum", "strings": [1, 9]}, "strings[1]"),
    ({"type": "release", "what": "everything"}, "what"),
    ({"type": "bend", "string": 1, "semitones": 4}, "semitones"),
    ([1, 2], "message"),
])
def test_bad_messages_name_their_field(message, field):
    s = engine.Session("steel-acoustic", 44100, BLOCK)
    with pytest.raises(engine.LiveError) as err:
        s.push(message)
    assert err.value.field == field, err.value


def test_a_second_bend_waits_for_the_first_to_return():
    s = engine.Session("steel-acoustic", 44100, BLOCK)
    s.push({"type": "bend", "string": 2, "semitones": 1})
    s.block()
    with pytest.raises(engine.LiveError, match="release"):
        s.push({"type": "bend", "string": 2, "semitones": 2})
    s.push({"type": "release", "string": 2, "what": "bend"})
    for _ in range(60):  # rise and return take the bend's duration (0.15 s) each
        s.block()
    s.push({"type": "vibrato", "string": 2, "duration": 0.2})


def test_a_copy_of_a_prepared_session_plays_the_same():
    """The live worker prepares a guitar once and opens each session as a copy of it."""
    template = engine.Session("steel-acoustic", 44100, BLOCK)
    copied = play(copy.deepcopy(template), PLAN, 100)
    assert np.array_equal(copied, play(template, PLAN, 100))


# ---- the waveguide model (``model="waveguide"``) -------------------------------------------------

def _scaled(plan: dict, block: int) -> dict:
    """PLAN at about the same times for blocks of ``block`` frames, the bend ``offset`` into its
    block (so that it does not fall on the waveguide kernel's 256-step grid)."""
    out = {int(b * BLOCK / block): copy.deepcopy(msgs) for b, msgs in plan.items()}
    out[int(20 * BLOCK / block)][0]["offset"] = 37
    return out


def _waveguide_live(block: int, delay: int | None = None, **opts) -> tuple[np.ndarray, np.ndarray]:
    s = engine.Session("steel-acoustic", 44100, block, record=True, model="waveguide",
                       options=RenderOptions(**opts))
    if delay is not None:
        s.delay = delay
    live = play(s, _scaled(PLAN, block), int(100 * BLOCK / block))
    ref = np.concatenate(list(engine.blocks(s.scene(), block, RenderOptions(live_grid=True,
                                                                            **opts))))
    return live, ref


@pytest.mark.parametrize("block", [BLOCK, 250])
def test_waveguide_session_equals_the_offline_render_of_its_events(block):
    """To the bit (the decayed-string skip off on both sides), with blocks on the kernel's
    256-step grid and off it: events act ``waveguide.LIVE_DELAY`` frames after their block."""
    live, ref = _waveguide_live(block, skip_decayed=False)
    assert np.max(np.abs(live)) > 0.05
    assert np.array_equal(live, ref)
    assert engine.Session(model="waveguide").delay == engine.waveguide.LIVE_DELAY == 256


def test_waveguide_session_with_the_decay_skip_equals_the_render():
    live, ref = _waveguide_live(BLOCK)
    assert np.array_equal(live, ref)


@pytest.mark.parametrize("skip_decayed", [True, False])
def test_a_waveguide_session_holds_damped_strings_at_rest_as_a_render_does(skip_decayed):
    """Fretted notes ended by a palm with rests between them: the hand holds each muted string
    at rest once it is silent (``kernel._settle``), deciding from what is known ``LOOKAHEAD``
    steps ahead (the palm's end is unknown to the session until its release is pushed), so the
    session gives the render's samples, with the decay stop and without it."""
    plan: dict[int, list] = {}
    for k in range(3):
        b = 2 + 250 * k  # 1.45 s apart: each muted string falls silent (within about 1 s) and
        string = 3 + k % 2  # rests before its next note
        plan[b] = [{"type": "fret", "string": string, "fret": 5 + k},
                   {"type": "pluck", "string": string, "force": 2.0, "offset": 11}]
        plan[b + 20] = [{"type": "mute", "string": string, "amount": 1.0, "offset": 5}]
        plan[b + 240] = [{"type": "release", "string": string, "what": "mute", "offset": 9}]
    s = engine.Session("steel-acoustic", 44100, BLOCK, record=True, model="waveguide",
                       options=RenderOptions(skip_decayed=skip_decayed))
    live = play(s, plan, 2 + 250 * 3 + 10)
    rests = sum(int(v.st["rests"]) for v in s.voices)
    ref = np.concatenate(list(engine.blocks(s.scene(), BLOCK,
                                            RenderOptions(live_grid=True,
                                                          skip_decayed=skip_decayed))))
    assert rests >= 2
    assert np.max(np.abs(live)) > 0.05
    assert np.array_equal(live, ref)


def test_waveguide_events_acting_at_once_would_change_what_was_decided():
    """Why the delay: the kernel fixes the period's stretch and the collision points it checks
    up to 256 steps ahead, so an event acting sooner after the block that learns of it (here a
    bend 37 frames into a block of 250) is heard differently from the render of the same
    events."""
    live, ref = _waveguide_live(250, delay=0, skip_decayed=False)
    assert not np.array_equal(live, ref)


def test_a_long_waveguide_session_prunes_and_stays_exact():
    plan = _long_plan(harmonics=True)
    s = engine.Session("steel-acoustic", 44100, BLOCK, record=True, model="waveguide",
                       options=RenderOptions(skip_decayed=False))
    live = play(s, plan, 2 + 3 * 90 + 10)
    assert len(s._events[2]) < 40  # pruned (the record keeps every event)
    ref = np.concatenate(list(engine.blocks(s.scene(), BLOCK,
                                            RenderOptions(live_grid=True, skip_decayed=False))))
    assert np.array_equal(live, ref)


def test_waveguide_strings_at_rest_cost_nothing_and_a_bend_waits():
    s = engine.Session("steel-acoustic", 44100, BLOCK, model="waveguide")
    assert not np.any(s.block())
    assert s.active_strings() == []
    s.push({"type": "pluck", "string": 1})
    s.push({"type": "bend", "string": 2, "semitones": 1})
    for _ in range(4):
        s.block()
    assert s.active_strings() == [1, 2]
    with pytest.raises(engine.LiveError, match="release"):
        s.push({"type": "bend", "string": 2, "semitones": 2})
    s.push({"type": "release", "string": 2, "what": "bend"})
    for _ in range(60):
        s.block()
    s.push({"type": "vibrato", "string": 2, "duration": 0.2})


def test_a_copy_of_a_prepared_waveguide_session_plays_the_same():
    template = engine.Session("steel-acoustic", 44100, BLOCK, model="waveguide")
    copied = play(copy.deepcopy(template), PLAN, 100)
    assert np.array_equal(copied, play(template, PLAN, 100))


def test_a_waveguide_session_damps_a_held_note_as_a_render_does():
    """A note held at fret 12 of string 2 (where the finite-difference finger damps the steel
    set's held notes most of frets 1, 5 and 12): the session's audio is the plain offline render
    of its events (not a live-grid one) to the bit, and its fundamental decays faster than with
    the finger's damping left out by the finger's rate D (``finger_decay_db_s``) to 0.2 dB/s,
    as an offline render's does (``tests/engine/waveguide/test_finger_damping.py``)."""
    from engine import waveguide
    from engine.analysis import decay_db_per_s
    from engine.models import PRESSED_STRING
    from engine.waveguide.fingering import finger_decay_db_s

    string, fret = 2, 12
    s = engine.Session("steel-acoustic", 44100, BLOCK, record=True, model="waveguide")
    plan = {1: [{"type": "fret", "string": string, "fret": fret}],
            2: [{"type": "pluck", "string": string}]}
    live = play(s, plan, int(1.3 * 44100 / BLOCK))
    scene = s.scene()
    assert np.array_equal(live, np.concatenate(list(engine.blocks(scene, BLOCK))))
    undamped = waveguide.render(engine.parse_scene(scene), waveguide.WaveguideOptions(
        finger_damping=False), statics=PRESSED_STRING) * engine.FIXED_GAIN
    preset = engine.get_preset("steel-acoustic")
    f = preset.strings[string - 1].frequency_hz * 2 ** (fret / 12)
    start = next(e["time"] for e in scene["events"] if e["type"] == "pluck")
    d_live = decay_db_per_s(live, 44100, f, start + 0.2, start + 1.15)
    d_off = decay_db_per_s(undamped, 44100, f, start + 0.2, start + 1.15)
    d = finger_decay_db_s(PRESSED_STRING, preset, string, 44100.0, fret)
    print(f"finger {d:+.2f} dB/s; live {d_live:+.2f}, without the finger {d_off:+.2f}")
    assert d < -1.0
    assert abs((d_live - d_off) - d) < 0.2


@pytest.mark.parametrize("strings, field, text", [
    ([{"string": 6, "nut_compensation_m": 0.001}], "guitar.strings", "string 6 outside 1..4"),
    ([{"string": 2, "nut_compensation_m": 0.009}], "guitar.strings[0].nut_compensation_m",
     "less than or equal to 0.007"),
])
def test_a_bad_guitar_in_the_open_names_its_field(strings, field, text):
    """The guitar's cross-field checks (a string the preset lacks) name the field as its own
    checks do, not the whole message."""
    with pytest.raises(engine.LiveError) as err:
        engine.parse_live_open({"guitar": {"preset": "bass", "strings": strings}})
    assert err.value.field == field, err.value
    assert text in err.value.message and not err.value.message.startswith(field), err.value


def test_an_unknown_model_is_refused_naming_the_field():
    with pytest.raises(engine.LiveError) as err:
        engine.parse_live_open({"preset": "steel-acoustic", "model": "spline"})
    assert err.value.field == "model" and "waveguide" in err.value.message
    assert engine.parse_live_open({"model": "waveguide"}).model == "waveguide"
    assert engine.parse_live_open({}).model == "fdtd"
    with pytest.raises(ValueError, match="model"):
        engine.Session(model="spline")


@pytest.mark.parametrize("model", ["fdtd", "waveguide"])
def test_pruning_keeps_a_lift_while_a_finger_it_lifted_is_kept(model):
    """A string's list past the pruning size when a fret-0 lift comes and just after it: the lift
    is kept while the finger it lifted is (dropped, the finger was held again when the string was
    compiled: the pull-off from fret 7 then fell back onto fret 5, not the open string)."""
    plan: dict[int, list] = {1: [{"type": "fret", "string": 2, "fret": 5}]}
    for k in range(70):  # ten soft plucks a block: more than 64 events within 50 ms
        plan.setdefault(2 + k // 10, []).append({"type": "pluck", "string": 2, "force": 0.3,
                                                 "offset": 25 * (k % 10)})
    plan[8].append({"type": "fret", "string": 2, "fret": 0, "offset": 100})
    plan[10] = [{"type": "pluck", "string": 2}]
    plan[12] = [{"type": "hammer_on", "string": 2, "fret": 7}]
    plan[20] = [{"type": "pull_off", "string": 2, "fret": 7}]
    plan[80] = [{"type": "pluck", "string": 2}]  # the waveguide's plucks are over by then
    s = engine.Session("steel-acoustic", 44100, BLOCK, record=True, model=model,
                       options=RenderOptions(skip_decayed=False))
    live = play(s, plan, 90)
    assert len(s._events[2]) < len(s.recorded)  # pruned (the record keeps every event)
    assert np.array_equal(live, offline(s, skip_decayed=False))
