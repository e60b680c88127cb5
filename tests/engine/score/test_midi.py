"""MIDI files we did not write (music21's and miditoolkit's test files) and small ones made here:
every file becomes a scene whose labels agree one to one with the file's notes, by a fingering with
no impossible assignment that moves the hand less than the greedy baseline."""

from __future__ import annotations

import bisect
import io
import os
import re
import warnings

import mido
import pretty_midi
import pytest

from engine.scene import parse_scene
from engine.score import fingering, scene_notes, score_to_scene
from engine.score.common import preset_tuning

from .conftest import check_scene, corpus, match_labels, no_overlap


def _files(collecting: bool = False):
    return corpus("midi", "*.mid", collecting)


def _pm(path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return pretty_midi.PrettyMIDI(path)


@pytest.mark.parametrize("path", _files(collecting=True), ids=os.path.basename)
def test_midi_file_becomes_scene_with_matching_labels(path):
    scene = score_to_scene(path, all_instruments=True)
    check_scene(scene)
    labels = scene_notes(scene)
    assert not match_labels(scene, labels)
    assert len(labels) == len(scene.notes)
    no_overlap(labels)
    # against the file itself (pretty_midi's notes): each note is labelled at its onset with its
    # pitch, or a warning names it (moved by octaves: the label is that many octaves off; or left
    # out: no label)
    src = [n for inst in _pm(path).instruments if not inst.is_drum for n in inst.notes]
    moved = sum(1 for w in scene.warnings if "outside the instrument's range" in w)
    dropped = sum(1 for w in scene.warnings if "left out (no string" in w)
    # tracks beyond a scene's 16, left out with their notes (the warning counts those it had)
    dropped += sum(int(m.group(1)) for w in scene.warnings
                   if (m := re.search(r"at most \d+ tracks, and it has fewer notes \((\d+)\)", w)))
    assert len(labels) == len(src) - dropped
    times = sorted((n["time"], n["pitch"]) for n in labels)
    keys = [t for t, _ in times]
    exact = octave = 0
    for n in src:
        lo = bisect.bisect_left(keys, n.start - 1e-5)
        hi = bisect.bisect_right(keys, n.start + 1e-5)
        got = [p for _, p in times[lo:hi]]
        if any(abs(p - n.pitch) < 0.01 for p in got):
            exact += 1
        elif any(abs(p - n.pitch) % 12 < 0.01 for p in got):
            octave += 1
    assert exact + octave >= len(src) - dropped
    assert octave <= moved + dropped


@pytest.mark.parametrize("path", _files(collecting=True), ids=os.path.basename)
def test_fingering_is_playable_and_beats_greedy(path):
    """No two notes on one string at once, no chord wider than 5 frets or needing more than four
    fingers, and less hand movement than the greedy lowest-fret assignment."""
    total_v = total_g = 0.0
    for inst in _pm(path).instruments:
        if inst.is_drum or not inst.notes:
            continue
        tuning = preset_tuning("steel-acoustic")
        notes = sorted(inst.notes, key=lambda n: (n.start, n.pitch))
        t = [n.start for n in notes]
        e = [n.end for n in notes]
        p = [n.pitch for n in notes]
        v = fingering.viterbi(t, e, p, tuning, 20)
        g = fingering.greedy(t, e, p, tuning, 20)
        for idx in fingering._slices(t):
            pos = [v.position[i] for i in idx if v.position[i] is not None]
            assert len({s for s, _ in pos}) == len(pos)  # one note per string
            fretted = [f for _, f in pos if f > 0]
            if fretted:
                assert max(fretted) - min(fretted) <= fingering.MAX_SPAN
            assert fingering._fingers([f for _, f in pos]) <= fingering.MAX_FINGERS
            for i in idx:
                if v.position[i] is not None:
                    s, f = v.position[i]
                    assert tuning[s - 1] + f == v.pitch[i]
        by_string = {}
        for i, pos in enumerate(v.position):
            if pos is not None:
                by_string.setdefault(pos[0], []).append(i)
        for idx in by_string.values():
            idx.sort(key=lambda i: t[i])
            for a, b in zip(idx, idx[1:], strict=False):
                assert v.end[a] <= t[b] + 1e-9
        mv, mg = fingering.measure(v, t), fingering.measure(g, t)
        total_v += mv["mean_move"] * mv["placed"]
        total_g += mg["mean_move"] * mg["placed"]
    assert total_v <= total_g + 1e-9  # equal where the greedy path is already the shortest


def test_all_midi_files_move_less_than_greedy():
    v_all = g_all = 0.0
    for path in _files():
        for inst in _pm(path).instruments:
            if inst.is_drum or not inst.notes:
                continue
            notes = sorted(inst.notes, key=lambda n: (n.start, n.pitch))
            t, e, p = [n.start for n in notes], [n.end for n in notes], [n.pitch for n in notes]
            tuning = preset_tuning("steel-acoustic")
            v_all += fingering.measure(fingering.viterbi(t, e, p, tuning, 20), t)["mean_move"]
            g_all += fingering.measure(fingering.greedy(t, e, p, tuning, 20), t)["mean_move"]
    assert v_all < 0.8 * g_all


def _midi(notes, program=25, bends=(), tempo=500000, channel=0) -> bytes:
    """A one-track MIDI file: notes (start beat, length beats, pitch, velocity), bends (beat, value)."""
    mid = mido.MidiFile(ticks_per_beat=480)
    tr = mido.MidiTrack()
    mid.tracks.append(tr)
    msgs = [(0, mido.MetaMessage("set_tempo", tempo=tempo)),
            (0, mido.Message("program_change", program=program, channel=channel))]
    for b, ln, p, v in notes:
        msgs.append((int(b * 480), mido.Message("note_on", note=p, velocity=v, channel=channel)))
        msgs.append((int((b + ln) * 480) - 1, mido.Message("note_off", note=p, channel=channel)))
    for b, val in bends:
        msgs.append((int(b * 480), mido.Message("pitchwheel", pitch=val, channel=channel)))
    msgs.sort(key=lambda m: m[0])
    last = 0
    for t, m in msgs:
        tr.append(m.copy(time=t - last))
        last = t
    buf = io.BytesIO()
    mid.save(file=buf)
    return buf.getvalue()


def test_program_velocity_bend_and_range():
    data = _midi([(0, 1, 64, 100), (1, 1, 67, 40), (2, 2, 30, 80)], program=27,
                 bends=[(1.2, 0), (1.4, 4096), (1.7, 4096), (1.9, 0)])
    scene = score_to_scene(data)
    check_scene(scene)
    tr = scene["tracks"][0]
    assert tr["guitar"]["preset"] == "electric"
    plucks = [e for e in tr["events"] if e["type"] == "pluck"]
    assert plucks[0]["force"] > plucks[1]["force"]  # velocity 100 > 40
    bends = [e for e in tr["events"] if e["type"] == "bend"]
    assert len(bends) == 1 and bends[0]["semitones"] == pytest.approx(1.0, abs=0.01)
    assert bends[0]["time"] == pytest.approx(1.2 * 0.5, abs=1e-3)
    assert any("F#1 outside the instrument's range, played as F#2" in w for w in scene.warnings)
    # a note ends with its string damped, unless the next note on that string follows at once
    damps = {(e["string"], e["time"]) for e in tr["events"] if e["type"] == "damp"}
    for n in scene.notes:
        after = [m for m in scene.notes if m["string"] == n["string"] and m["time"] > n["time"]]
        if not after or after[0]["time"] - n["end"] > 0.005:
            assert (n["string"], n["end"]) in damps, n
    labels = scene_notes(scene)
    assert [round(n["pitch"]) for n in labels] == [64, 67, 42]


def test_bass_and_nylon_programs_and_drums_left_out():
    for program, preset in ((33, "bass"), (24, "nylon-classical"), (0, "steel-acoustic")):
        scene = score_to_scene(_midi([(0, 1, 45, 90)], program=program),
                               all_instruments=True)
        assert scene["tracks"][0]["guitar"]["preset"] == preset
    mid = mido.MidiFile(file=io.BytesIO(_midi([(0, 1, 45, 90)])))
    drum = mido.MidiTrack([mido.Message("note_on", note=36, velocity=100, channel=9),
                           mido.Message("note_off", note=36, channel=9, time=100)])
    mid.tracks.append(drum)
    buf = io.BytesIO()
    mid.save(file=buf)
    scene = score_to_scene(buf.getvalue())
    assert len(scene["tracks"]) == 1
    assert any("percussion" in w for w in scene.warnings)


def test_tempo_scale_and_max_seconds():
    data = _midi([(b, 1, 60 + b, 90) for b in range(8)])
    a = score_to_scene(data)
    b = score_to_scene(data, tempo_scale=2.0)
    assert [n["time"] * 0.5 for n in a.notes] == pytest.approx([n["time"] for n in b.notes])
    c = score_to_scene(data, max_seconds=1.0)
    assert c["duration"] == 1.0 and all(e["time"] < 1.0 for e in c["tracks"][0]["events"])
    assert len(c.notes) == 2


def test_a_score_of_more_tracks_than_a_scene_holds_keeps_the_busiest():
    """A MIDI file of 20 parts (20 tracks on the 15 pitched channels): the scene keeps the 16
    with the most notes, in the score's order, and the warnings name the four left out."""
    channels = [c for c in range(16) if c != 9]  # channel 10 (9) is percussion
    from engine.scene import MAX_TRACKS

    mid = mido.MidiFile()
    for part in range(20):
        tr = mido.MidiTrack()
        mid.tracks.append(tr)
        tr.append(mido.Message("program_change", program=25, channel=channels[part % 15], time=0))
        for k in range(1 + part):  # part p plays p + 1 notes: the first four are the quietest
            tr.append(mido.Message("note_on", note=52 + k % 12, velocity=80, channel=channels[part % 15],
                                   time=0 if k == 0 else 240))
            tr.append(mido.Message("note_off", note=52 + k % 12, velocity=0, channel=channels[part % 15],
                                   time=200))
    buf = io.BytesIO()
    mid.save(file=buf)
    scene = score_to_scene(buf.getvalue())
    assert len(scene["tracks"]) == MAX_TRACKS
    left_out = [w for w in scene.warnings if "left out: a scene holds at most" in w]
    assert len(left_out) == 4
    assert len(parse_scene(scene).tracks) == MAX_TRACKS  # the engine takes it
    kept = {t["name"] for t in scene["tracks"]}
    assert {n["track_name"] for n in scene.notes} == kept
    assert len(scene.notes) == sum(range(5, 21))  # the notes of the 16 busiest parts
