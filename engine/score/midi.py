"""Standard MIDI File -> scene, read with pretty_midi (which reads with mido).

* Before anything is built, ``scan`` walks the file's chunks and events once (no objects per event)
  and refuses a file that is truncated, not a MIDI file, or holds more than ``MAX_NOTES`` notes.
* **Tracks**: one scene track per part of the file as pretty_midi splits it (per MIDI track, channel
  and program); drum parts (channel 10) are left out, with a warning.  The General MIDI program
  picks the preset (``common.preset_for_program``: 24 nylon, 25 steel, 26-31 electric, 32-39 bass,
  any other instrument the steel-string guitar).
* **Time**: the file's tempo map, as pretty_midi applies it; ``tempo_scale`` divides every time.
* **Notes**: strings and frets by ``fingering.viterbi`` on the preset's tuning and frets; velocity
  -> force (``common.force_for_velocity``); a note outside the instrument is moved by octaves into
  it, a chord too large or too wide for a hand loses the fewest notes; each is a warning naming
  its time, bar, beat, track and pitch.  Every note ends with a ``damp`` (``common.string_events``).
* **Pitch bend**: each rise of the pitch wheel and its return (range from RPN 0 if the file sets
  it, else 2 semitones) becomes a ``bend`` on the strings that sound then; a bend downwards cannot be
  played (the engine raises tension only) and is a warning.
"""

from __future__ import annotations

import bisect
import io
import warnings as _warnings

from . import common as C
from . import fingering
from .common import Planned, ScoreError

MAX_MIDI_TRACKS = 256


def _varlen(d: bytes, i: int, end: int) -> tuple[int, int]:
    v = 0
    for _ in range(4):
        if i >= end:
            raise ScoreError("MIDI file is truncated inside an event")
        b = d[i]
        i += 1
        v = (v << 7) | (b & 0x7F)
        if not b & 0x80:
            return v, i
    raise ScoreError("MIDI file is corrupt: a variable-length number longer than 4 bytes")


def scan(data: bytes) -> int:
    """Check a Standard MIDI File's structure and count its notes, refusing more than
    ``MAX_NOTES``, without building anything per event.  Returns the note count."""
    if data[:4] == b"RIFF":
        k = data.find(b"MThd")
        if k < 0:
            raise ScoreError("RIFF file without a MIDI header ('MThd')")
        data = data[k:]
    if len(data) < 14 or data[:4] != b"MThd":
        raise ScoreError("not a MIDI file or truncated: no complete 'MThd' header")
    hlen = int.from_bytes(data[4:8], "big")
    fmt = int.from_bytes(data[8:10], "big")
    ntrks = int.from_bytes(data[10:12], "big")
    division = int.from_bytes(data[12:14], "big")
    if hlen < 6 or fmt > 2:
        raise ScoreError(f"MIDI header is corrupt (length {hlen}, format {fmt})")
    if division == 0:
        raise ScoreError("MIDI header is corrupt: 0 ticks per quarter note")
    if ntrks == 0 or ntrks > MAX_MIDI_TRACKS:
        raise ScoreError(f"MIDI file declares {ntrks} tracks (allowed 1..{MAX_MIDI_TRACKS})")
    pos, found, notes = 8 + hlen, 0, 0
    n = len(data)
    while found < ntrks:
        if pos + 8 > n:
            raise ScoreError(f"MIDI file is truncated: {found} of its {ntrks} tracks present")
        cid = data[pos:pos + 4]
        clen = int.from_bytes(data[pos + 4:pos + 8], "big")
        pos += 8
        if pos + clen > n:
            raise ScoreError(f"MIDI file is truncated: track {found + 1} declares {clen} bytes, "
                             f"{n - pos} remain")
        if cid == b"MTrk":
            notes += _walk(data, pos, pos + clen, found + 1)
            if notes > C.MAX_NOTES:
                raise ScoreError(f"MIDI file has more than {C.MAX_NOTES} notes")
            found += 1
        pos += clen
    return notes


def _walk(d: bytes, i: int, end: int, track: int) -> int:
    status, notes = None, 0
    while i < end:
        _, i = _varlen(d, i, end)
        if i >= end:
            raise ScoreError(f"MIDI track {track} is truncated after a delta time")
        b = d[i]
        if b == 0xFF:
            i += 2
            length, i = _varlen(d, i, end)
            i += length
        elif b in (0xF0, 0xF7):
            length, i = _varlen(d, i + 1, end)
            i += length
        else:
            if b & 0x80:
                status = b
                i += 1
            elif status is None:
                raise ScoreError(f"MIDI track {track} is corrupt: data byte without a status")
            hi = status & 0xF0
            if hi == 0xF0:
                raise ScoreError(f"MIDI track {track} is corrupt: system message {status:#x} in "
                                 "a file")
            if hi == 0x90 and i + 1 < end and d[i + 1] > 0:
                notes += 1
                if notes > C.MAX_NOTES:
                    raise ScoreError(f"MIDI file has more than {C.MAX_NOTES} notes")
            i += 1 if hi in (0xC0, 0xD0) else 2
        if i > end:
            raise ScoreError(f"MIDI track {track} is truncated inside an event")
    return notes


def _parse(data: bytes):
    import pretty_midi

    scan(data)
    try:
        with _warnings.catch_warnings():
            _warnings.simplefilter("ignore")
            return pretty_midi.PrettyMIDI(io.BytesIO(data))
    except ScoreError:
        raise
    except Exception as exc:
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ScoreError(f"MIDI file is corrupt: {msg}"[:300]) from None


def _bend_range(inst) -> float:
    """Semitones of the pitch wheel's full throw: RPN 0 (CC 101 = 0, CC 100 = 0, then CC 6), else 2."""
    msb = lsb = None
    rng = 2.0
    for cc in sorted(inst.control_changes, key=lambda c: c.time):
        if cc.number == 101:
            msb = cc.value
        elif cc.number == 100:
            lsb = cc.value
        elif cc.number == 6 and msb == 0 and lsb == 0:
            rng = float(cc.value)
    return rng if rng > 0 else 2.0


def _humps(bends, rng, scale):
    """Pitch-wheel events -> [(start, peak semitones, peak time, release time, end)] and the time
    of the first downward bend (None if there is none)."""
    pts = [(b.time / scale, b.pitch / 8192.0 * rng) for b in sorted(bends, key=lambda b: b.time)]
    humps, down, i = [], None, 0
    while i < len(pts):
        if pts[i][1] < -0.05 and down is None:
            down = pts[i][0]
        if pts[i][1] <= 0.05:
            i += 1
            continue
        start = pts[i - 1][0] if i else pts[i][0]
        j = i
        while j < len(pts) and pts[j][1] > 0.05:
            j += 1
        seg = pts[i:j]
        peak = max(v for _, v in seg)
        tp = next(t for t, v in seg if v >= 0.9 * peak)
        tr = max(t for t, v in seg if v >= 0.9 * peak)
        te = pts[j][0] if j < len(pts) else None
        humps.append((start, peak, tp, tr, te))
        i = j
    return humps, down


def convert(data: bytes, options: dict, warnings: list[str]) -> tuple[dict, list[Planned]]:
    pm = _parse(data)
    scale = float(options.get("tempo_scale", 1.0))
    want = options.get("tracks")
    preset_opt = options.get("presets")
    try:
        beats = [float(b) for b in pm.get_beats()]
        downbeats = [float(b) for b in pm.get_downbeats()]
    except Exception:
        beats, downbeats = [], []

    def where(t_file: float) -> str:
        bar = bisect.bisect_right(downbeats, t_file + 1e-6)
        beat_i = bisect.bisect_right(beats, t_file + 1e-6)
        first = bisect.bisect_left(beats, downbeats[bar - 1] - 1e-6) if bar else 0
        return f"{t_file / scale:.3f} s (bar {max(bar, 1)}, beat {max(beat_i - first, 1)})"


    scene_tracks, planned, frets_of = [], [], []
    names = _part_names(pm.instruments)
    for number, inst in enumerate(pm.instruments, start=1):
        name = names[number - 1]
        label = f"track '{name}' ({number})"
        if want is not None and number not in want and name not in want \
                and inst.name.strip() not in want:
            continue
        if inst.is_drum:
            warnings.append(f"{label}: a percussion part, left out")
            continue
        if not inst.notes:
            continue
        if want is None and not options.get("all_instruments") and \
                not C.is_guitar_program(inst.program):
            C.skip_instrument(label, inst.program, warnings)
            continue
        preset = C.preset_for_program(inst.program)
        if isinstance(preset_opt, str):
            preset = preset_opt
        elif isinstance(preset_opt, dict):
            preset = preset_opt.get(number, preset_opt.get(str(number), preset_opt.get(name, preset)))
        from .. import presets as _presets

        if preset not in _presets.PRESETS:
            raise ScoreError(f"options.presets: unknown preset {preset!r}; choose one of "
                             f"{sorted(_presets.PRESETS)}")
        tuning = C.preset_tuning(preset)
        frets = _presets.get_preset(preset).frets
        notes = sorted(inst.notes, key=lambda n: (n.start, n.pitch))
        times = [n.start / scale for n in notes]
        ends = [max(n.end / scale, n.start / scale + 1e-3) for n in notes]
        fing = fingering.viterbi(times, ends, [n.pitch for n in notes], tuning, frets)
        ti = len(scene_tracks)
        style = "pick" if preset in ("electric", "steel-acoustic") else "finger"
        mine = []
        for i, n in enumerate(notes):
            w = f"{where(n.start)}, {label}"
            name_p = C.midi_name(n.pitch)
            if i in fing.dropped or fing.position[i] is None:
                warnings.append(f"{w}: note {name_p} left out (no string free or within the "
                                "hand's reach in this chord)")
                continue
            if i in fing.moved:
                warnings.append(f"{w}: note {name_p} outside the instrument's range, played as "
                                f"{C.midi_name(fing.pitch[i])}")
            s, f = fing.position[i]
            p = Planned(ti, s, f, times[i], fing.end[i], C.force_for_velocity(n.velocity),
                        float(fing.pitch[i]), style=style, where=w)
            mine.append(p)
        _bends(inst, mine, scale, warnings, label, where)
        planned.extend(mine)
        frets_of.append(frets)
        scene_tracks.append({"name": name, "guitar": {"preset": preset}, "events": [],
                             "gain_db": 0.0, "pan": 0.0})
    if not scene_tracks:
        if want is None and any("options.all_instruments" in w for w in warnings):
            raise ScoreError("the MIDI file has no guitar or bass part (options.all_instruments "
                             "plays its other instruments on guitars)")
        raise ScoreError("the MIDI file has no pitched notes to play" if want is None else
                         f"options.tracks: none of {sorted(map(str, want))} is a pitched part "
                         "of this file")
    by_string: dict[tuple[int, int], list[Planned]] = {}
    for p in planned:
        by_string.setdefault((p.track, p.string), []).append(p)
    for (ti, _s), notes in sorted(by_string.items()):
        scene_tracks[ti]["events"].extend(C.string_events(notes, frets_of[ti]))
    last = 0.0
    for tr in scene_tracks:
        tr["events"].sort(key=lambda e: e["time"])
        for e in tr["events"]:
            last = max(last, e["time"], e.get("release", 0.0))
    last = max([last] + [p.end for p in planned])
    return {"duration": round(last + C.TAIL_S, 6), "sample_rate": 44100,
            "tracks": scene_tracks, "score": timing(pm, beats, downbeats, scale)}, planned


def timing(pm, beats: list[float], downbeats: list[float], scale: float) -> dict:
    """The file's bars, beats and tempo map in seconds as played (``engine.scene.ScoreInfo``),
    from pretty_midi's beats and downbeats (a dotted beat in compound meters); the title is the
    first track's name, as a sequencer writes it."""
    bars = [round(t / scale, 6) for t in downbeats]
    out_beats, positions = [], []
    k, first = -1, 0
    for i, t in enumerate(beats):
        while k + 1 < len(downbeats) and downbeats[k + 1] <= t + 1e-9:
            k += 1
            first = bisect.bisect_left(beats, downbeats[k] - 1e-9)
        out_beats.append(round(t / scale, 6))
        positions.append(i - first + 1)
    try:
        times, qpm = pm.get_tempo_changes()
    except Exception:
        times, qpm = [], []
    tempo: list[dict] = []
    for t, q in zip(times, qpm, strict=True):
        t, q = round(float(t) / scale, 6), round(float(q) * scale, 4)
        if tempo and tempo[-1]["time"] == t:
            tempo.pop()
        if (not tempo or tempo[-1]["bpm"] != q) and 0 < q <= 20000:
            tempo.append({"time": t, "bpm": q})
    return {"bars": bars, "bar_numbers": list(range(1, len(bars) + 1)), "beats": out_beats,
            "beat_positions": positions, "tempo": tempo}


def _part_names(instruments) -> list[str]:
    """Each part's name: its track name; the General MIDI instrument where the name is missing
    or shared with another part ("Piano" twice -> "Piano (Acoustic Grand Piano)", and a number
    after that where even those agree)."""
    import pretty_midi

    raw = [i.name.strip() for i in instruments]
    count: dict[str, int] = {}
    for r in raw:
        count[r] = count.get(r, 0) + 1
    names = []
    for r, inst in zip(raw, instruments, strict=True):
        gm = "Drums" if inst.is_drum else pretty_midi.program_to_instrument_name(inst.program)
        names.append(gm if not r else f"{r} ({gm})" if count[r] > 1 else r)
    seen: dict[str, int] = {}
    total: dict[str, int] = {}
    for n in names:
        total[n] = total.get(n, 0) + 1
    out = []
    for n in names:
        seen[n] = seen.get(n, 0) + 1
        out.append(f"{n} {seen[n]}" if total[n] > 1 else n)
    return out


def _bends(inst, notes: list[Planned], scale, warnings, label, where):
    if not inst.pitch_bends:
        return
    humps, down = _humps(inst.pitch_bends, _bend_range(inst), scale)
    if down is not None:
        warnings.append(f"{where(down * scale)}, {label}: downward pitch bends (this one and any "
                        "later) not playable (the engine raises a string's tension only), ignored")
    for start, peak, tp, tr, te in humps:
        if peak > 3.0:
            warnings.append(f"{where(start * scale)}, {label}: pitch bend of {peak:.2f} semitones "
                            "limited to 3")
            peak = 3.0
        end = te if te is not None else max((p.end for p in notes), default=start)
        for p in notes:
            if p.time < start < p.end:
                # rise and return within the note, so that the string's next note starts unbent
                rise = max(min(tp - start, (p.end - start) / 3.0), 1e-3)
                rel = max(min(tr, p.end - rise), start + rise)
                p.bends.append((start, round(peak, 4), rise, rel))
                if "bend" not in p.articulations:
                    p.articulations.append("bend")
            elif start <= p.time < end:  # a note struck while the wheel is up: bent before
                bt = max(p.time - 0.03, 0.0)
                r = max(min(0.02, p.time - bt, (p.end - bt) / 3.0), 1e-3)
                rel = max(min(tr, p.end - r), bt + r)
                p.bends.append((bt, round(peak, 4), r, rel))
                p.pitch += peak
                p.articulations.append("prebend")
