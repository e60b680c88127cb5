"""Guitar Pro 3/4/5 -> scene, read with PyGuitarPro.

What is kept and how (``../shared/API.md``, "Scores in"):

* **Tracks**: one scene track per pitched track; percussion tracks are left out (a warning says
  so).  The preset comes from the track's General MIDI instrument and string count
  (``common.preset_for_program``); the track's own tuning is kept as ``guitar.tuning`` with one note
  per string (a 7-string guitar or a 5-string bass asks for a preset extended to that many strings).
  A **capo** raises the tuning by its frets (the scene has no capo; the tab's frets count from it).
  Fret numbers above the preset's fret count raise ``guitar.frets`` (up to 24).
* **Time**: the tempo map (the song's tempo and every mix-table tempo change, at the beat that
  carries it), **repeats** and **alternate endings** are expanded into one playback order of
  measures (``playback_order``); **triplet feel** (eighths or sixteenths) swings the positions
  inside each beat 2:1; both **voices** of a Guitar Pro 5 measure are played; **ties** lengthen
  the note they continue (and carry its bends and vibrato on); rests are silence.
* **Dynamics** -> force (``common.force_for_velocity``); accents x1.25, heavy accents x1.5, ghost
  notes x0.5.
* **Effects** -> articulations: bend curves -> ``bend`` events (one per rise-and-return of the
  curve; a pre-bend is put on before the attack); slides into and out of a note, legato slides and
  shift slides -> ``slide``; hammer-on/pull-off -> ``hammer_on``/``pull_off`` on the next note of the
  string; natural, artificial, tapped and pinch harmonics -> a ``harmonic`` touch at the exact node;
  palm mute -> ``mute``; dead notes -> a touch at a point that is no partial's node; vibrato ->
  ``vibrato``; let ring -> no damp at the note's end; staccato -> half the length; grace notes ->
  a note of their own before (or on) the beat, joined to the main note by their transition; trill
  -> alternating hammer-ons and pull-offs; tremolo picking -> repeated plucks; strokes -> ``strum``;
  tapping/slapping/popping -> ``tap`` or the pluck's style.
* **Directions** (D.C., D.S., al Fine, al Coda, To Coda) are followed once each (see
  ``playback_order``).
* What cannot be played (tremolo bar, fade-in, a direction whose sign is missing, bends beyond the
  engine's range ...) is listed in the warnings, each naming bar, beat, track and effect.
"""

from __future__ import annotations

import io
import math
from dataclasses import dataclass

from .. import presets as _presets
from ..performance import strum_times
from . import common as C
from .common import Planned, ScoreError


def _guarded_reader(base):
    """A PyGuitarPro reader class that refuses counts beyond our limits before acting on them."""

    class Guarded(base):
        _beats = 0

        def readMeasureHeaders(self, song, measureCount, *args):
            if not 0 < measureCount <= C.MAX_MEASURES:
                raise ScoreError(f"Guitar Pro file declares {measureCount} measures "
                                 f"(allowed 1..{C.MAX_MEASURES})")
            return super().readMeasureHeaders(song, measureCount, *args)

        def readTracks(self, song, trackCount, *args):
            if not 0 < trackCount <= C.MAX_TRACKS:
                raise ScoreError(f"Guitar Pro file declares {trackCount} tracks "
                                 f"(allowed 1..{C.MAX_TRACKS})")
            return super().readTracks(song, trackCount, *args)

        def readBeat(self, *args, **kw):
            self._beats += 1
            if self._beats > C.MAX_BEATS:
                raise ScoreError(f"Guitar Pro file has more than {C.MAX_BEATS} beats")
            return super().readBeat(*args, **kw)

        def readVoice(self, start, voice):
            pos = self.data.tell()
            beats = self.readI32()
            if not 0 <= beats <= 1024:
                raise ScoreError(f"Guitar Pro file declares {beats} beats in one measure "
                                 "(allowed 0..1024)")
            self.data.seek(pos)
            return super().readVoice(start, voice)

    Guarded.__name__ = "Guarded" + base.__name__
    return Guarded


def parse_song(data: bytes):
    """PyGuitarPro's ``Song`` from the file's bytes, or a ``ScoreError`` naming what is wrong."""
    import guitarpro
    from guitarpro import io as gpio
    from guitarpro.iobase import GPFileBase

    if len(data) < 31:
        raise ScoreError(f"not a Guitar Pro file: {len(data)} bytes is shorter than its header")
    if data[:4] == b"PK\x03\x04":
        raise ScoreError("a zip archive (Guitar Pro 6/7 .gpx/.gp or another format), not a "
                         "Guitar Pro 3/4/5 file")
    fp = io.BytesIO(data)
    version = GPFileBase(fp, "cp1252").readVersion()
    try:
        vt, cls = gpio.getVersionAndGPFile(version)
    except guitarpro.GPException:
        raise ScoreError("not a Guitar Pro 3/4/5 file (unknown header "
                         f"{version[:30]!r})") from None
    reader = _guarded_reader(cls)(fp, "cp1252", version=version, versionTuple=vt)
    try:
        return reader.readSong()
    except ScoreError:
        raise
    except RecursionError:
        raise ScoreError("Guitar Pro file is malformed (nesting too deep)") from None
    except MemoryError:
        raise ScoreError("Guitar Pro file too large to read") from None
    except Exception as exc:  # struct.error at EOF, bad enum values, GPException ...
        cause = exc.__cause__ or exc
        if isinstance(cause, ScoreError):
            raise cause from None
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        if "unpack requires" in msg or "buffer" in msg:
            msg = f"file ends early ({msg})"
        raise ScoreError(f"Guitar Pro file is truncated or corrupt: {msg}"[:300]) from None


def _name(d) -> str | None:
    return d.name if d is not None and d.name else None


def playback_order(headers, skipped: list[str] | None = None) -> list[int]:
    """Measure indices in the order they are played: repeats (``repeatClose`` = times repeated)
    and alternate endings (bit k of ``repeatAlternative`` = played on pass k+1) expanded.  A
    section starts at a repeat sign, after a finished repeat, or after its last ending.

    Directions (Guitar Pro 5): at the end of a measure marked "Da Capo ..." or "Da Segno ..."
    (once each) playing goes back to the start or to the Segno (Segno Segno) sign; from then on
    repeats are not taken again and only the last of a run of endings is played; "... al Fine"
    stops after the Fine measure, "... al Coda" ("al Double Coda") jumps from the measure marked
    "Da Coda" ("Da Double Coda") to the Coda (Double Coda) sign.  Directions whose sign is
    missing are listed in ``skipped``."""
    order: list[int] = []
    marks: dict[str, int] = {}
    for k, h in enumerate(headers):
        name = _name(h.direction)
        if name is not None:
            marks.setdefault(name, k)
    i, start, passno, furthest, after_alt = 0, 0, 0, -1, False
    jumped: str | None = None
    taken: set[int] = set()
    n = len(headers)
    while i < n:
        h = headers[i]
        alt = h.repeatAlternative
        if jumped is None:
            if i > furthest and (h.isRepeatOpen or (after_alt and not alt)):
                start, passno = i, 0
            furthest = max(furthest, i)
            after_alt = bool(alt)
            if alt and not (alt >> passno) & 1:
                i += 1
                continue
        elif alt and i + 1 < n and headers[i + 1].repeatAlternative:
            i += 1  # after a D.C./D.S. only the last ending is played
            continue
        order.append(i)
        if len(order) > C.MAX_PLAYED_MEASURES:
            raise ScoreError(f"repeats expand to more than {C.MAX_PLAYED_MEASURES} measures")
        if jumped is None and h.repeatClose > 0:
            if passno < h.repeatClose:
                passno += 1
                i = start
                continue
            start = i + 1
            if not (i + 1 < n and headers[i + 1].repeatAlternative):
                passno = 0
        go = _name(h.fromDirection)
        if jumped is not None:
            if jumped.endswith("al Fine") and marks.get("Fine") == i:
                break
            for sign in ("Double Coda", "Coda"):
                if go == f"Da {sign}" and jumped.endswith(f"al {sign}") and sign in marks:
                    i = marks[sign]
                    jumped += " (done)"
                    break
            else:
                i += 1
            continue
        if go is not None and (go.startswith("Da Capo") or go.startswith("Da Segno")) \
                and i not in taken:
            taken.add(i)
            if go.startswith("Da Capo"):
                target = 0
            else:
                target = marks.get("Segno Segno" if go.startswith("Da Segno Segno") else "Segno")
            wanted = next((s for s in ("Double Coda", "Coda", "Fine") if go.endswith(f"al {s}")),
                          None)
            if target is None or (wanted is not None and wanted not in marks):
                if skipped is not None:
                    skipped.append(f"bar {i + 1}: direction '{go}' not followed (its sign is "
                                   "missing)")
            else:
                jumped = go
                i = target
                continue
        i += 1
    return order


class _Clock:
    """Ticks of the played (repeat-expanded) score -> seconds, through the tempo map."""

    def __init__(self, song, order, tempo_scale: float):
        self.quarter = 960
        self.headers = song.measureHeaders
        changes: dict[int, list[tuple[int, float]]] = {}
        for track in song.tracks:
            for m_index, measure in enumerate(track.measures):
                for voice in measure.voices:
                    for beat in voice.beats:
                        mix = beat.effect.mixTableChange
                        if mix is not None and mix.tempo is not None and mix.tempo.value > 0:
                            off = beat.start - measure.header.start
                            changes.setdefault(m_index, []).append((off, float(mix.tempo.value)))
        self.starts = []  # playback tick at which each played measure starts
        tick = 0
        seg_ticks, seg_bpm = [0], [float(song.tempo if song.tempo > 0 else 120)]
        for m in order:
            self.starts.append(tick)
            for off, bpm in sorted(changes.get(m, [])):
                seg_ticks.append(tick + max(off, 0))
                seg_bpm.append(bpm)
            tick += self.headers[m].length
        self.end_tick = tick
        self.seg_ticks, self.seg_bpm = seg_ticks, seg_bpm
        self.scale = tempo_scale
        self.seg_sec = [0.0]
        for k in range(1, len(seg_ticks)):
            dt = seg_ticks[k] - seg_ticks[k - 1]
            self.seg_sec.append(self.seg_sec[-1] + dt * 60.0 / (seg_bpm[k - 1] * 960 * tempo_scale))

    def seconds(self, tick: float) -> float:
        import bisect

        k = bisect.bisect_right(self.seg_ticks, tick) - 1
        k = max(k, 0)
        return self.seg_sec[k] + (tick - self.seg_ticks[k]) * 60.0 / (
            self.seg_bpm[k] * 960 * self.scale)


def _swing(offset: float, feel) -> float:
    """Triplet feel: inside each beat unit the first half takes 2/3 of it, the second 1/3."""
    name = getattr(feel, "name", "none")
    if name == "none":
        return offset
    unit = 960.0 if name == "eighth" else 480.0
    base = math.floor(offset / unit) * unit
    p = offset - base
    half = unit / 2
    if p <= half:
        return base + p * (2.0 / 3.0) / 0.5
    return base + unit * 2.0 / 3.0 + (p - half) * (1.0 / 3.0) / 0.5


@dataclass
class _Track:
    index: int  # scene track index
    number: int  # Guitar Pro track number (1-based)
    name: str
    preset: str
    tuning: list[int]  # MIDI, string 1 first, capo included
    frets: int


def _bend_humps(points):
    """Bend points (position 0..12, value in quarter tones) -> humps
    [(start_pos, peak_semitones, peak_pos, fall_pos or None)] and whether the curve was
    simplified (a partial release or a second rise without returning to zero)."""
    pts = sorted((p.position / 12.0, p.value / 2.0) for p in points)
    humps = []
    approx = False
    i = 0
    n = len(pts)
    while i < n:
        # skip zeros
        while i < n and pts[i][1] <= 0:
            i += 1
        if i >= n:
            break
        start = pts[i - 1][0] if i > 0 else pts[i][0]
        pre = i == 0 or pts[i - 1][1] <= 0 and pts[i][0] == pts[i - 1][0]
        j = i
        peak, peak_pos = pts[i][1], pts[i][0]
        while j < n and pts[j][1] > 0:
            if pts[j][1] > peak:
                peak, peak_pos = pts[j][1], pts[j][0]
            j += 1
        # points i..j-1 are > 0; the hump returns to zero at j (or never)
        vals = [v for _, v in pts[i:j]]
        top = [k for k, v in enumerate(vals) if v == peak]
        if any(abs(v - peak) > 1e-9 for v in vals[top[0]:top[-1] + 1]) or any(
                vals[k] > vals[k + 1] + 1e-9 for k in range(top[0])) or any(
                vals[k] < vals[k + 1] - 1e-9 for k in range(top[-1], len(vals) - 1)):
            approx = True
        if i == 0 and pts[0][1] > 0:
            pre = True
        fall = pts[i + top[-1]][0] if j < n else None
        humps.append((start, peak, peak_pos, fall, pre))
        i = j
    return humps, approx


def convert(song, options: dict, warnings: list[str]) -> tuple[dict, list[Planned]]:
    """The scene (JSON form, with ``tracks``) of a PyGuitarPro song, and its planned notes."""
    tempo_scale = float(options.get("tempo_scale", 1.0))
    want = options.get("tracks")
    preset_opt = options.get("presets")
    skipped: list[str] = []
    order = playback_order(song.measureHeaders, skipped)
    clock = _Clock(song, order, tempo_scale)
    warnings.extend(f"{w.split(':', 1)[0]}, beat 1, track all:{w.split(':', 1)[1]}"
                    for w in skipped)
    tracks: list[_Track] = []
    scene_tracks: list[dict] = []
    planned: list[Planned] = []
    strums: list[tuple[int, dict]] = []
    for t in song.tracks:
        label = f"track '{t.name}' ({t.number})"
        if want is not None and t.number not in want and t.name not in want:
            continue
        if t.isPercussionTrack:
            warnings.append(f"{label}: a percussion track, left out")
            continue
        n_strings = len(t.strings)
        if not 1 <= n_strings <= 12:
            warnings.append(f"bar 1, beat 1, {label}: {n_strings} strings, left out"
                            + (" (a notation staff without tablature)" if not n_strings else ""))
            continue
        program = t.channel.instrument
        if want is None and not options.get("all_instruments") and \
                not C.is_guitar_program(program):
            C.skip_instrument(f"bar 1, beat 1, {label}", program, warnings)
            continue
        preset = C.preset_for_program(program, n_strings)
        if isinstance(preset_opt, str):
            preset = preset_opt
        elif isinstance(preset_opt, dict):
            preset = preset_opt.get(t.number, preset_opt.get(str(t.number),
                                    preset_opt.get(t.name, preset)))
        if preset not in _presets.PRESETS:
            raise ScoreError(f"options.presets: unknown preset {preset!r}; choose one of "
                             f"{sorted(_presets.PRESETS)}")
        capo = max(int(t.offset or 0), 0)
        tuning = [s.value + capo for s in sorted(t.strings, key=lambda s: s.number)]
        bad = [p for p in tuning if not 25.0 <= 440 * 2 ** ((p - 69) / 12) <= 1400.0]
        if bad:
            names = [C.midi_name(p) for p in bad]
            warnings.append(f"bar 1, beat 1, {label}: tuning {names} outside the strings' "
                            "range 25..1400 Hz, left out")
            continue
        base_frets = _presets.get_preset(preset).frets
        tr = _Track(len(tracks), t.number, t.name or f"Track {t.number}", preset, tuning, base_frets)
        notes_before = len(planned)
        _track_notes(song, t, tr, order, clock, planned, strums, warnings, label, capo)
        used = max((n.fret for n in planned[notes_before:]), default=0)
        used = max([used] + [n.slide_in or 0 for n in planned[notes_before:]]
                   + [n.slide_out or 0 for n in planned[notes_before:]])
        guitar = {"preset": preset, "tuning": [C.midi_name(p) for p in tuning]}
        if used > base_frets:
            guitar["frets"] = min(used, 24)
            tr.frets = guitar["frets"]
        if capo:
            warnings.append(f"bar 1, beat 1, {label}: capo at fret {capo} played as strings "
                            f"tuned {capo} semitones up")
        balance = getattr(t.channel, "balance", 64)
        volume = getattr(t.channel, "volume", 104)
        tracks.append(tr)
        scene_tracks.append({"name": tr.name, "guitar": guitar, "events": [],
                             "gain_db": round(20 * math.log10(max(volume, 1) / 104.0), 2),
                             "pan": round(min(max((balance - 64) / 64.0, -1.0), 1.0), 3)})
    if not scene_tracks:
        if want is None and any("options.all_instruments" in w for w in warnings):
            raise ScoreError("the score has no guitar or bass track (options.all_instruments "
                             "plays its other instruments on guitars)")
        raise ScoreError("the score has no pitched track to play" if want is None else
                         f"options.tracks: none of {sorted(map(str, want))} is a pitched track "
                         "of this score")
    scene = _assemble(scene_tracks, tracks, planned, strums, warnings)
    scene["score"] = {"title": song.title or "", "artist": song.artist or "",
                      **timing(song.measureHeaders, order, clock)}
    return scene, planned


def beat_unit(numerator: int, denominator: int) -> tuple[int, float]:
    """(beats in a bar, quarter notes per beat) of a time signature: the denominator's note,
    or a dotted one in compound meters (6/8, 9/8, 12/8 ...: a numerator > 3 divisible by 3), as
    pretty_midi counts the beats of a MIDI file."""
    quarters = 4.0 / denominator
    if numerator > 3 and numerator % 3 == 0:
        return numerator // 3, 3 * quarters
    return numerator, quarters


def timing(headers, order, clock) -> dict:
    """Bars and beats in seconds as played (``ScoreInfo`` of ``engine.scene``): each played
    bar's start and number, each beat's time and place in its bar, and the tempo map (quarter
    notes per minute, the tempo scale applied)."""
    bars, numbers, beats, positions = [], [], [], []
    for k, m in enumerate(order):
        h = headers[m]
        start = clock.starts[k]
        bars.append(_r6(clock.seconds(start)))
        numbers.append(m + 1)
        count, quarters = beat_unit(h.timeSignature.numerator, h.timeSignature.denominator.value)
        step = quarters * clock.quarter
        for j in range(count):
            if j * step >= h.length:
                break
            beats.append(_r6(clock.seconds(start + j * step)))
            positions.append(j + 1)
    tempo: list[dict] = []
    for tick, bpm in zip(clock.seg_ticks, clock.seg_bpm, strict=True):
        t, q = _r6(clock.seconds(tick)), round(bpm * clock.scale, 4)
        if tempo and tempo[-1]["time"] == t:
            tempo.pop()
        if not tempo or tempo[-1]["bpm"] != q:
            tempo.append({"time": t, "bpm": q})
    return {"bars": bars, "bar_numbers": numbers, "beats": beats, "beat_positions": positions,
            "tempo": tempo}


def _r6(x: float) -> float:
    return round(float(x), 6)


def _assemble(scene_tracks, tracks, planned, strums, warnings) -> dict:
    by_string: dict[tuple[int, int], list[Planned]] = {}
    for n in planned:
        by_string.setdefault((n.track, n.string), []).append(n)
    dropped = set()
    for (ti, s), notes in by_string.items():  # one note per string at a time
        notes.sort(key=lambda n: n.time)
        kept = []
        for n in notes:
            if kept and n.time - kept[-1].time < 1e-3:
                warnings.append(f"{n.where}: a second note on string {s} at the same time "
                                f"(fret {n.fret} beside fret {kept[-1].fret}), left out")
                dropped.add(id(n))
                continue
            kept.append(n)
        by_string[(ti, s)] = kept
    planned[:] = [n for n in planned if id(n) not in dropped]
    last = 0.0
    for (ti, _s), notes in sorted(by_string.items()):
        evs = C.string_events(notes, tracks[ti].frets)
        scene_tracks[ti]["events"].extend(evs)
    for ti, ev in strums:
        scene_tracks[ti]["events"].append(ev)
    for tr in scene_tracks:
        tr["events"].sort(key=lambda e: e["time"])
        for e in tr["events"]:
            last = max(last, e["time"], e.get("release", 0.0))
    for n in planned:
        last = max(last, n.end)
    return {"duration": round(last + C.TAIL_S, 6), "sample_rate": 44100, "tracks": scene_tracks}


def _track_notes(song, t, tr: _Track, order, clock, planned, strums, warnings, label, capo):
    n_strings = len(tr.tuning)
    open_by_string = {i + 1: tr.tuning[i] for i in range(n_strings)}
    last_on_string: dict[int, Planned] = {}
    pending_legato: dict[int, tuple[str, Planned]] = {}  # string -> (kind, previous note)
    taken: dict[tuple[int, float], int] = {}  # (string, beat time) -> fret, across voices
    for k, m in enumerate(order):
        measure = t.measures[m]
        header = measure.header
        mstart = clock.starts[k]
        for v_index, voice in enumerate(measure.voices):
            for b_index, beat in enumerate(voice.beats):
                if not beat.notes:
                    continue
                where = f"bar {m + 1}, beat {b_index + 1}"
                if v_index:
                    where += f" (voice {v_index + 1})"
                w = f"{where}, {label}"
                off0 = beat.start - header.start
                dur_ticks = beat.duration.time
                a = _swing(off0, header.tripletFeel)
                b = _swing(off0 + dur_ticks, header.tripletFeel)
                t0 = clock.seconds(mstart + a)
                t1 = clock.seconds(mstart + b)
                spt = clock.seconds(mstart + off0 + 1) - clock.seconds(mstart + off0)  # s / tick
                be = beat.effect
                if be.isTremoloBar:
                    warnings.append(f"{w}: tremolo bar not playable (the engine bends strings "
                                    "only upwards), ignored")
                if be.fadeIn:
                    warnings.append(f"{w}: fade-in (volume swell) not playable, ignored")
                if be.hasRasgueado:
                    warnings.append(f"{w}: rasgueado played as one strum")
                style = "pick" if tr.preset in ("electric", "steel-acoustic") else "finger"
                slap = be.slapEffect.name if be.isSlapEffect else None
                if slap == "slapping":
                    style = "slap"
                elif slap == "popping":
                    style = "pop"
                stroke = be.stroke.direction.name if be.stroke.direction.value else None
                if be.hasRasgueado and stroke is None:
                    stroke = "down"
                beat_notes = []
                for note in beat.notes:
                    s = note.string
                    if not 1 <= s <= n_strings:
                        warnings.append(f"{w}: note on string {s} of a {n_strings}-string track, "
                                        "left out")
                        continue
                    nt = note.type.name
                    eff = note.effect
                    if nt == "rest":
                        continue
                    if nt == "tie":
                        prev = last_on_string.get((v_index, s)) or last_on_string.get(s)
                        if prev is not None and prev.end >= t0 - 0.02:
                            prev.end = max(prev.end, t1)
                            _continuation_effects(prev, eff, be, t0, t1, w, warnings)
                            continue
                        warnings.append(f"{w}: tie with no note before it on string {s}, "
                                        "played as a new note")
                    fret = int(note.value)
                    other = taken.get((s, round(t0, 4)))
                    if other is not None:
                        warnings.append(f"{w}: a second note on string {s} at the same time "
                                        f"(fret {fret} beside fret {other}), left out")
                        continue
                    if fret < 0 or fret > 24:
                        warnings.append(f"{w}: fret {fret} outside 0..24, note left out")
                        continue
                    velocity = note.velocity
                    force = C.force_for_velocity(velocity)
                    if eff.accentuatedNote:
                        force *= 1.25
                    if eff.heavyAccentuatedNote:
                        force *= 1.5
                    if eff.ghostNote:
                        force *= 0.5
                    force = min(max(force, 0.05), 20.0)
                    end = t1
                    if eff.staccato:
                        end = t0 + 0.5 * (t1 - t0)
                    elif getattr(note, "durationPercent", 1.0) and note.durationPercent < 1.0:
                        end = t0 + max(note.durationPercent, 0.1) * (t1 - t0)
                    pitch = open_by_string[s] + fret
                    p = Planned(tr.index, s, fret, t0, end, force, float(pitch), style=style,
                                where=w)
                    p.let_ring = bool(eff.letRing)
                    if nt == "dead":
                        p.dead = True
                        p.touch = _touch(tr, s, fret, C.DEAD_TOUCH)
                        p.articulations.append("dead")
                    if eff.palmMute:
                        p.palm_mute = 0.6
                        p.articulations.append("palm_mute")
                    if slap == "tapping":
                        if fret >= 1:
                            p.attack = "tap"
                            p.articulations.append("tap")
                        else:
                            warnings.append(f"{w}: tapping an open string, plucked instead")
                    elif slap:
                        p.articulations.append({"slapping": "slap", "popping": "pop"}[slap])
                    if eff.isHarmonic and not p.dead:
                        _harmonic(p, eff.harmonic, tr, s, fret, w, warnings)
                    if eff.vibrato or be.vibrato:
                        depth = 40.0 if be.vibrato else 20.0
                        p.vibrato = (depth, 5.5, t0, max(end - t0, 1e-3))
                        p.articulations.append("vibrato")
                    if eff.isBend:
                        _bend(p, eff.bend.points, t0, end, w, warnings, "bend")
                    # legato from the previous note on this string (its hammer/slide flag)
                    leg = pending_legato.pop(s, None)
                    prev = last_on_string.get(s)
                    if leg is not None and prev is not None and abs(prev.end - t0) < 0.05 \
                            and p.attack == "pluck" and not p.dead:
                        kind = leg[0]
                        _legato(p, prev, kind, w, warnings)
                    for sl in eff.slides:
                        _slide(p, sl.name, tr, w, warnings, pending_legato)
                    if eff.hammer:
                        pending_legato[s] = ("hammer", p)
                    if eff.letRing:
                        p.articulations.append("let_ring")
                    if eff.staccato:
                        p.articulations.append("staccato")
                    if eff.isGrace:
                        g = _grace(p, eff.grace, tr, s, spt, w, warnings, planned)
                        if g is not None:
                            last_on_string[s] = g
                    expanded = [p]
                    if eff.isTrill:
                        expanded = _trill(p, eff.trill, tr, s, spt, t0, end, w, warnings)
                    elif eff.isTremoloPicking:
                        expanded = _tremolo(p, eff.tremoloPicking, spt, t0, end)
                    planned.extend(expanded)
                    taken[(s, round(t0, 4))] = fret
                    last_on_string[s] = last_on_string[(v_index, s)] = expanded[-1]
                    beat_notes.append(p)
                if stroke and beat_notes:
                    plucked = [n for n in beat_notes if n.attack == "pluck"]
                    if len(plucked) >= 1:
                        strings = [n.string for n in plucked]
                        value = be.stroke.value or 16
                        spread = 4 * 960 / value * spt
                        spread = min(spread, 0.5 * (t1 - t0), 0.5)
                        direction = "down" if stroke == "down" else "up"
                        force = sum(n.force for n in plucked) / len(plucked)
                        # from the strum event's own (rounded) numbers, so that the notes'
                        # times are the ones the engine and the labels derive from the event
                        spread = round(spread, 6)
                        times = dict(strum_times(round(t0, 6), strings, direction, spread,
                                                 len(tr.tuning)))
                        for n in plucked:
                            n.attack = "strum"
                            n.time = times[n.string]
                            n.end = max(n.end, n.time + 1e-3)
                            n.articulations.append(f"strum_{direction}")
                        strums.append((tr.index, C.strum_event(
                            t0, strings, direction, spread, force, 0.8, plucked[0].style)))


def _touch(tr: _Track, string: int, fret: int, rel: float) -> float:
    """x / L (of the whole string) of a touch at ``rel`` of the speaking length from ``fret`` to
    the bridge, with the preset's geometry (scale, saddle setback and nut compensation)."""
    preset = _presets.get_preset(tr.preset)
    s = min(string, preset.n_strings)
    length = preset.string_length_m(s)
    x_stop = float(preset.fret_x_m(fret, preset.strings[s - 1])) if fret > 0 else 0.0
    x = x_stop + (length - x_stop) * rel
    return min(max(x / length, 0.021), 0.979)


# natural-harmonic frets -> (node numerator j, mode k): the touch at j/k of the string
_NATURAL = {12: (1, 2), 7: (1, 3), 19: (2, 3), 5: (1, 4), 24: (3, 4), 4: (1, 5), 9: (2, 5),
            16: (3, 5), 3: (1, 6), 15: (5, 6), 2: (1, 7), 17: (4, 7), 22: (5, 7), 10: (4, 9)}


def _harmonic(p: Planned, h, tr, s, fret, w, warnings):
    kind = type(h).__name__
    if kind == "NaturalHarmonic":
        jk = _NATURAL.get(fret)
        if jk is None:
            warnings.append(f"{w}: natural harmonic at fret {fret} is at no low partial's node, "
                            "played as a fretted note")
            return
        j, k = jk
        p.fret = 0
        p.touch = _touch(tr, s, 0, j / k)
        p.pitch = tr.tuning[s - 1] + 12 * math.log2(k)
        p.articulations.append("natural_harmonic")
    elif kind in ("ArtificialHarmonic", "TappedHarmonic"):
        if kind == "TappedHarmonic" and h.fret:
            dist = int(h.fret) - fret if int(h.fret) > fret else int(h.fret)
        else:
            dist = 12
        ratio = 2.0 ** (-dist / 12.0)  # the touch point's share of the speaking length, from it
        rel = 1.0 - ratio
        k = next((k for k in range(2, 17) if abs(k * rel - round(k * rel)) < 0.02
                  and round(k * rel) >= 1), None)
        if k is None:
            warnings.append(f"{w}: harmonic {dist} frets above the fretted note is at no low "
                            "partial's node, played as a fretted note")
            return
        j = round(k * rel)
        p.touch = _touch(tr, s, fret, j / k)
        p.pitch = tr.tuning[s - 1] + fret + 12 * math.log2(k)
        p.articulations.append("artificial_harmonic" if kind == "ArtificialHarmonic"
                               else "tapped_harmonic")
    elif kind == "PinchHarmonic":
        # the picking thumb grazes the string where the pick is, 1/5 of the speaking length from
        # the bridge: the 5th partial's node (two octaves and a major third)
        p.touch = _touch(tr, s, fret, 4 / 5)
        p.position = min(max(p.touch + 0.02, 0.02), 0.98)
        p.pitch = tr.tuning[s - 1] + fret + 12 * math.log2(5)
        p.articulations.append("pinch_harmonic")
    else:
        warnings.append(f"{w}: {kind} not playable, played as a plain note")


def _bend(p: Planned, points, t0, t1, w, warnings, what, tied: bool = False):
    """The bend curve ``points`` of the beat t0..t1 as ``bend`` events of note ``p``; a pre-bend
    (a curve that starts bent) is put on just before t0, and raises the pitch ``p`` is attacked
    at, unless the beat is ``tied``: a tie continues a note already sounding, whose attack it
    does not change."""
    humps, approx = _bend_humps(points)
    if approx:
        warnings.append(f"{w}: {what} curve with a partial release or re-bend approximated by "
                        "full rises and returns")
    dur = max(t1 - t0, 1e-3)
    for (start, peak, peak_pos, fall, pre) in humps:
        if peak > 3.0:
            warnings.append(f"{w}: {what} of {peak:g} semitones limited to 3 (the engine's "
                            "largest bend)")
            peak = 3.0
        if pre:
            bt = max(t0 - 0.03, 0.0)
            rise = max(min(0.02, t0 - bt), 1e-3)
        else:
            bt = t0 + start * dur
            rise = max((peak_pos - start) * dur, 0.005)
        # the engine returns over the rise time after ``release``: start back that much earlier,
        # and be back by the note's end, so that the string's next note starts unbent
        rise = max(min(rise, (t1 - bt) / 2.0), 1e-3)
        rel = t0 + fall * dur if fall is not None else t1 - rise
        rel = max(min(rel, t1 - rise), bt + rise)
        p.bends.append((bt, round(peak, 4), rise, rel))
        if pre and not tied and p.attack in ("pluck", "strum"):
            p.pitch += peak
    if humps and "bend" not in p.articulations:
        p.articulations.append("bend" if not humps[0][4] else "prebend")


def _continuation_effects(prev: Planned, eff, be, t0, t1, w, warnings):
    if eff.isBend:
        _bend(prev, eff.bend.points, t0, t1, w, warnings, "bend", tied=True)
    if eff.vibrato or be.vibrato:
        if prev.vibrato is None:
            prev.vibrato = (20.0, 5.5, t0, t1 - t0)
            prev.articulations.append("vibrato")
        else:
            d, r, st, _ = prev.vibrato
            prev.vibrato = (d, r, st, t1 - st)
    if eff.letRing:
        prev.let_ring = True


def _slide(p: Planned, kind: str, tr, w, warnings, pending):
    if kind in ("intoFromBelow", "intoFromAbove"):
        start = p.fret - 3 if kind == "intoFromBelow" else p.fret + 3
        start = min(max(start, 1), tr_frets(tr))
        if p.fret < 1 or start == p.fret:
            warnings.append(f"{w}: slide into an open string not playable, plucked plainly")
            return
        p.slide_in = start
        p.articulations.append("slide_in")
    elif kind in ("outDownwards", "outUpwards"):
        end = p.fret - 5 if kind == "outDownwards" else p.fret + 5
        end = min(max(end, 1), tr_frets(tr))
        if p.fret < 1 or end == p.fret:
            warnings.append(f"{w}: slide out of an open string not playable, ignored")
            return
        p.slide_out = end
        p.articulations.append("slide_out")
    elif kind in ("legatoSlideTo", "shiftSlideTo"):
        pending[p.string] = ("legato_slide" if kind == "legatoSlideTo" else "shift_slide", p)


def tr_frets(tr) -> int:
    return 24


def _legato(p: Planned, prev: Planned, kind: str, w, warnings):
    """The note ``p`` played legato from ``prev`` on the same string."""
    a, b = prev.fret, p.fret
    prev.let_ring = prev.let_ring  # the legato note itself keeps the string sounding
    if kind in ("legato_slide", "shift_slide"):
        if a >= 1 and b >= 1 and a != b:
            if kind == "legato_slide":
                p.attack = "slide"
                p.legato_from = a
                p.articulations.append("legato_slide")
            else:
                # the finger glides to the new fret just before it is picked again
                prev.slide_out = b
                p.articulations.append("shift_slide")
            return
        warnings.append(f"{w}: slide between frets {a} and {b} not playable (open string or "
                        "same fret), played as hammer-on/pull-off")
    if b > a:
        p.attack = "hammer_on"
        p.legato_from = a
        p.articulations.append("hammer_on")
    elif b < a:
        p.attack = "pull_off"
        p.legato_from = a
        p.articulations.append("pull_off")
    else:
        warnings.append(f"{w}: hammer-on to the same fret {b}, plucked again")


def _grace(p: Planned, g, tr, s, spt, w, warnings, planned) -> Planned | None:
    fret = int(g.fret)
    if not 0 <= fret <= 24:
        warnings.append(f"{w}: grace note at fret {fret} outside 0..24, left out")
        return None
    gd = spt * g.durationTime
    gd = min(gd, 0.5 * max(p.end - p.time, 1e-3), 0.12)
    old = p.time
    if g.isOnBeat or p.time < gd:  # (before the first beat there is no time to steal)
        gt = p.time
        p.time = p.time + gd
    else:
        gt = p.time - gd
    # the main note's pre-bend is put on after the grace note is struck, before its own attack
    for k, (bt, peak, rise, rel) in enumerate(p.bends):
        if bt < old - 1e-9:
            bt = max(p.time - (old - bt), 0.5 * (gt + p.time))
            rise = max(min(rise, p.time - bt), 1e-3)
            p.bends[k] = (bt, peak, rise, max(rel, bt + rise))
    force = C.force_for_velocity(g.velocity)
    gn = Planned(p.track, s, fret, gt, p.time, force, float(tr.tuning[s - 1] + fret),
                 style=p.style, where=w, articulations=["grace"])
    if g.isDead:
        gn.dead = True
        gn.touch = _touch(tr, s, fret, C.DEAD_TOUCH)
        gn.articulations.append("dead")
    planned.append(gn)
    trans = g.transition.name
    if trans == "slide":
        _legato(p, gn, "legato_slide", w, warnings)
    elif trans == "hammer":
        _legato(p, gn, "hammer", w, warnings)
    elif trans == "bend":
        warnings.append(f"{w}: grace-note bend transition played as a hammer-on/pull-off")
        _legato(p, gn, "hammer", w, warnings)
    return gn


def _trill(p: Planned, trill, tr, s, spt, t0, t1, w, warnings) -> list[Planned]:
    other = int(trill.fret)
    period = max(spt * trill.duration.time, 0.03)
    if not 0 <= other <= 24 or other == p.fret:
        warnings.append(f"{w}: trill to fret {other} not playable, played as one note")
        return [p]
    out = [p]
    t = t0 + period
    frets = [other, p.fret]
    k = 0
    while t < t1 - 0.25 * period and len(out) < 256:
        f = frets[k % 2]
        q = Planned(p.track, s, f, t, t1, p.force, float(tr.tuning[s - 1] + f), style=p.style,
                    where=w, articulations=["trill"], repeat=True)
        prev = out[-1]
        prev.end = t
        q.attack = "hammer_on" if f > prev.fret else "pull_off"
        q.legato_from = prev.fret
        out.append(q)
        t += period
        k += 1
    if "trill" not in p.articulations:
        p.articulations.append("trill")
    return out


def _tremolo(p: Planned, trem, spt, t0, t1) -> list[Planned]:
    period = max(spt * trem.duration.time, 0.03)
    out = [p]
    t = t0 + period
    while t < t1 - 0.25 * period and len(out) < 512:
        q = Planned(p.track, p.string, p.fret, t, t1, p.force, p.pitch, style=p.style,
                    where=p.where, articulations=["tremolo_picking"], palm_mute=p.palm_mute,
                    repeat=True)
        out[-1].end = t
        out[-1].let_ring = True  # the next pick stops it
        out.append(q)
        t += period
    p.articulations.append("tremolo_picking")
    return out
