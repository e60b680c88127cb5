"""MusicXML (``.musicxml``, ``.xml``, compressed ``.mxl``; partwise and timewise) -> PyGuitarPro's
song model, which ``gp.convert`` maps to a scene as it does every Guitar Pro file.

* **Parts** -> tracks: the General MIDI program of ``<midi-instrument>`` (else "guitar"/"bass" in
  the part's name, else piano), the tuning of a tablature staff (``<staff-tuning>``; else standard
  guitar, or bass for a bass part), capo (``<capo>``).
* **Time**: ``<divisions>``, each note's ``<duration>`` (tuplets included), ``<backup>`` and
  ``<forward>``, chords, voices; grace notes take no time (they become Guitar Pro grace notes);
  tempo from ``<sound tempo>``; repeats (``<repeat>`` forward/backward, ``times``) and endings
  (``<ending number>``), D.C./D.S./Fine/Coda from ``<sound>``'s attributes.
* **Notes**: pitch, ties (``<tie type="stop">`` continues the note), dynamics (``<sound
  dynamics>``, a percentage of forte); where the note has tablature technicals they are kept:
  ``<string>``/``<fret>``, ``<hammer-on>``/``<pull-off>``, ``<bend>`` (``<bend-alter>``, release,
  pre-bend), ``<harmonic>`` (natural, artificial), slides (``<slide>``/``<glissando>`` start), palm
  mute (``<other-technical>`` "palm mute"/"P.M."), dead notes (``<notehead>x``), staccato,
  accents, vibrato (``<wavy-line>``), ``<tremolo>`` (single), ``<arpeggiate>`` (a strum up, down
  with ``direction="down"``), ``<tap>``.  A note without ``<string>``/``<fret>`` gets them from
  ``fingering.viterbi`` over its part, as MIDI notes do.
"""

from __future__ import annotations

import zipfile
from fractions import Fraction

from . import common as C
from . import fingering
from .common import ScoreError
from .gpif import MAX_GPIF_BYTES, parse_xml, zip_member

_STEPS = {"C": 0, "D": 2, "E": 4, "F": 5, "G": 7, "A": 9, "B": 11}
GUITAR = [64, 59, 55, 50, 45, 40]
BASS = [43, 38, 33, 28]
Q = 960  # PyGuitarPro ticks per quarter note


def sniff(data: bytes) -> bool:
    head = data[:4096].lstrip(b"\xef\xbb\xbf \t\r\n")
    if data[:4] == b"PK\x03\x04":
        return b"META-INF/container.xml" in data[:1 << 20] or b".musicxml" in data[:1 << 16]
    return head.startswith(b"<") and (b"<score-partwise" in data[:8192]
                                      or b"<score-timewise" in data[:8192])


def unpack(data: bytes) -> bytes:
    """The MusicXML document of a .musicxml/.xml file or of a compressed .mxl (zip)."""
    if data[:4] != b"PK\x03\x04":
        return data
    return zip_member(data, _score_member, "MusicXML archive (.mxl)")


def _score_member(zf: zipfile.ZipFile) -> zipfile.ZipInfo:
    """The score an .mxl holds: the rootfile its container.xml names, else its first .musicxml or
    .xml outside META-INF."""
    name = None
    if "META-INF/container.xml" in zf.namelist():
        info = zf.getinfo("META-INF/container.xml")
        if info.file_size > 1 << 20:
            raise ScoreError("MusicXML archive's META-INF/container.xml is too large")
        root = parse_xml(zf.read(info), "MusicXML container.xml", allow_doctype=True)
        for el in root.iter():
            if el.tag.endswith("rootfile") and el.get("full-path"):
                name = el.get("full-path")
                break
    if name is None:
        name = next((n for n in zf.namelist() if n.lower().endswith((".musicxml", ".xml"))
                     and not n.startswith("META-INF")), None)
    if name is None:
        raise ScoreError("a zip archive without a MusicXML score: not a .mxl file")
    return zf.getinfo(name)


def _t(el, path, default=""):
    x = el.find(path) if el is not None else None
    return (x.text or "").strip() if x is not None and x.text else default


def _f(s, default=0.0):
    try:
        return float(s)
    except (TypeError, ValueError):
        return default


def _parts(root) -> list[tuple[str, list]]:
    """[(part id, [measure elements])] of a partwise or timewise score."""
    if root.tag == "score-partwise":
        return [(p.get("id", ""), p.findall("measure")) for p in root.findall("part")]
    if root.tag == "score-timewise":
        parts: dict[str, list] = {}
        for m in root.findall("measure"):
            for p in m.findall("part"):
                p.attrib.setdefault("number", m.get("number", ""))
                parts.setdefault(p.get("id", ""), []).append(p)
        return list(parts.items())
    raise ScoreError(f"not a MusicXML score: its root is <{root.tag}>")


def to_song(root, warnings: list[str]):
    import guitarpro.models as M

    parts = _parts(root)
    if not 0 < len(parts) <= C.MAX_TRACKS:
        raise ScoreError(f"MusicXML score has {len(parts)} parts (allowed 1..{C.MAX_TRACKS})")
    n_notes = sum(1 for _ in root.iter("note"))
    if n_notes > C.MAX_NOTES:
        raise ScoreError(f"MusicXML score has {n_notes} notes (allowed at most {C.MAX_NOTES})")
    n_measures = max(len(ms) for _, ms in parts)
    if not 0 < n_measures <= C.MAX_MEASURES:
        raise ScoreError(f"MusicXML score has {n_measures} measures (allowed 1..{C.MAX_MEASURES})")
    info = {}
    pl = root.find("part-list")
    for sp in pl.findall("score-part") if pl is not None else []:
        info[sp.get("id", "")] = sp
    song = M.Song(title=_t(root, "work/work-title") or _t(root, "movement-title"))
    song.tracks = []
    headers = []
    tempos: list[tuple[int, float]] = []  # (absolute tick, bpm)
    # measure lengths and repeat structure from the first part
    first = parts[0][1]
    start = Q
    divisions = 1
    beats_n, beat_type = 4, 4
    key = None
    for k in range(n_measures):
        m = first[k] if k < len(first) else None
        h = M.MeasureHeader(number=k + 1, start=start)
        h.chord_names = []  # (tick in the bar, JAMS chord) of its <harmony> (gp.harmony)
        length = 0
        pos = 0
        if m is not None:
            for el in m:
                if el.tag == "attributes":
                    divisions = int(_f(_t(el, "divisions"), divisions)) or divisions
                    if el.find("time") is not None:
                        beats_n = int(_f(_t(el, "time/beats").split("+")[0], 4)) or 4
                        beat_type = int(_f(_t(el, "time/beat-type"), 4)) or 4
                    if el.find("key/fifths") is not None:
                        key = (int(_f(_t(el, "key/fifths"), 0)), int(_t(el, "key/mode") == "minor"))
                elif el.tag == "harmony":
                    label = _harmony(el)
                    if label is not None:
                        h.chord_names.append((round(pos * Q / divisions), label))
                elif el.tag in ("note", "backup", "forward"):
                    if el.tag == "note" and (el.find("grace") is not None or
                                             el.find("chord") is not None):
                        continue
                    d = int(_f(_t(el, "duration"), 0))
                    pos += -d if el.tag == "backup" else d
                    length = max(length, pos)
                elif el.tag == "barline":
                    rep = el.find("repeat")
                    if rep is not None and rep.get("direction") == "forward":
                        h.isRepeatOpen = True
                    if rep is not None and rep.get("direction") == "backward":
                        h.repeatClose = max(min(int(_f(rep.get("times"), 2)) - 1, 100), 0)
                    end = el.find("ending")
                    if end is not None and end.get("type") == "start" or (
                            end is not None and not h.repeatAlternative):
                        for tok in (end.get("number") or "").replace(",", " ").split():
                            if tok.isdigit() and 1 <= int(tok) <= 8:
                                h.repeatAlternative |= 1 << (int(tok) - 1)
                for snd in ([el] if el.tag == "sound" else el.iter("sound")):
                    if snd.get("tempo"):
                        bpm = _f(snd.get("tempo"))
                        if 1 <= bpm <= 1000:
                            tempos.append((start + round(pos * Q / divisions), bpm))
                    for attr, name in (("segno", "Segno"), ("coda", "Coda"), ("fine", "Fine")):
                        if snd.get(attr) is not None and h.direction is None:
                            h.direction = M.DirectionSign(name)
                    if snd.get("dacapo", "").lower() == "yes":
                        h.fromDirection = M.DirectionSign("Da Capo")
                    elif snd.get("dalsegno") is not None:
                        h.fromDirection = M.DirectionSign("Da Segno")
                    elif snd.get("tocoda") is not None:
                        h.fromDirection = M.DirectionSign("Da Coda")
        full = Fraction(4 * beats_n, beat_type)  # quarter notes in the time signature
        played = Fraction(length, divisions)
        quarters = played if played > 0 and (m is not None and m.get("implicit") == "yes"
                                            or played != full) else full
        den = 4
        num = quarters * den / 4
        while num.denominator != 1 and den < 64:
            den *= 2
            num = quarters * den / 4
        h.timeSignature = M.TimeSignature(numerator=max(int(num), 1),
                                          denominator=M.Duration(value=den))
        if key is not None:
            try:
                h.keySignature = M.KeySignature(key)
            except ValueError:
                pass
        headers.append(h)
        start += h.length
    song.measureHeaders = headers
    for number, (pid, measures) in enumerate(parts, start=1):
        song.tracks.append(_track(M, song, number, info.get(pid), measures, headers, warnings))
    if tempos:
        tempos.sort()
        if tempos[0][0] == Q:
            song.tempo = tempos[0][1]
        tr = song.tracks[0]
        for tick, bpm in tempos:
            if tick == Q and bpm == song.tempo:
                continue
            k = max(i for i, hh in enumerate(headers) if hh.start <= tick)
            voice = tr.measures[k].voices[0]
            b = M.Beat(voice, start=tick, status=M.BeatStatus.empty)
            b.effect.mixTableChange = M.MixTableChange(tempo=M.MixTableItem(value=bpm))
            voice.beats.append(b)
    return song


def _pitch(n) -> int | None:
    p = n.find("pitch")
    if p is None:  # unpitched (percussion)
        return None
    step = _STEPS.get(_t(p, "step"), 0)
    return 12 * (int(_f(_t(p, "octave"), 4)) + 1) + step + round(_f(_t(p, "alter"), 0))


def _track(M, song, number, sp, measures, headers, warnings):
    name = (_t(sp, "part-name") or f"Part {number}") if sp is not None else f"Part {number}"
    program = int(_f(_t(sp, "midi-instrument/midi-program"), 0)) - 1 if sp is not None else -1
    channel = int(_f(_t(sp, "midi-instrument/midi-channel"), 1)) - 1 if sp is not None else 0
    lname = (name + " " + _t(sp, "score-instrument/instrument-name")).lower()
    if program < 0:
        program = 33 if "bass" in lname and "contrabass" not in lname else \
            25 if "guitar" in lname else 0
    tuning, capo = None, 0
    for m in measures:
        for sd in m.iter("staff-details"):
            lines = {}
            for st in sd.findall("staff-tuning"):
                step = _STEPS.get(_t(st, "tuning-step"), 0) + round(_f(_t(st, "tuning-alter")))
                lines[int(_f(st.get("line"), 0))] = 12 * (int(_f(_t(st, "tuning-octave"), 3))
                                                          + 1) + step
            if lines and tuning is None:
                tuning = [lines[k] for k in sorted(lines, reverse=True)]  # string 1 = top line
            if sd.find("capo") is not None:
                capo = int(_f(_t(sd, "capo"), 0))
    if tuning is None:
        tuning = BASS if 32 <= program <= 39 else GUITAR
    strings = [M.GuitarString(number=i + 1, value=v) for i, v in enumerate(tuning)]
    track = M.Track(song, number=number, name=name, offset=capo, strings=strings,
                    isPercussionTrack=channel == 9,
                    channel=M.MidiChannel(channel=max(channel, 0), instrument=program))
    track.measures = []
    events = []  # (measure index, voice, tick, duration ticks, note element, pitch, grace)
    divisions = 1
    for k, h in enumerate(headers):
        m = measures[k] if k < len(measures) else None
        pos = Fraction(0)
        last_start = Fraction(0)
        for el in (m if m is not None else []):
            if el.tag == "attributes":
                divisions = int(_f(_t(el, "divisions"), divisions)) or divisions
            elif el.tag == "backup":
                pos -= int(_f(_t(el, "duration"), 0))
            elif el.tag == "forward":
                pos += int(_f(_t(el, "duration"), 0))
            elif el.tag == "note":
                grace = el.find("grace") is not None
                d = Fraction(int(_f(_t(el, "duration"), 0)))
                at = last_start if el.find("chord") is not None else pos
                if not grace and el.find("chord") is None:
                    last_start = pos
                    pos += d
                    at = last_start
                voice = _t(el, "voice", "1")
                if el.find("rest") is None:
                    tick = h.start + at * Q / divisions
                    events.append((k, voice, tick, d * Q / divisions, el, _pitch(el), grace))
            pos = max(pos, Fraction(0))
    placed = _assign(events, tuning, track, warnings)
    voices: dict = {}
    for h in headers:
        measure = M.Measure(track, h)
        measure.voices = []
        track.measures.append(measure)
    order = sorted({v for _, v, *_ in events}) or ["1"]
    for k in range(len(headers)):
        for v in order:
            voice = M.Voice(track.measures[k])
            voice.beats = []
            track.measures[k].voices.append(voice)
            voices[(k, v)] = voice
    beats: dict = {}
    pending_grace: dict = {}
    for i, (k, v, tick, dur, el, _p, grace) in enumerate(events):
        pos = placed.get(i)
        if pos is None:
            continue
        s, fret, tie = pos
        if grace:
            pending_grace[(k, v, s)] = (fret, el)
            continue
        key = (k, v, tick)
        beat = beats.get(key)
        if beat is None:
            ticks = max(dur, Fraction(1))
            beat = M.Beat(voices[(k, v)], start=tick, status=M.BeatStatus.normal,
                          duration=M.Duration(value=1, tuplet=M.Tuplet(enters=3840,
                                                                        times=ticks)))
            beats[key] = beat
            voices[(k, v)].beats.append(beat)
        note = M.Note(beat, value=fret, string=s, type=M.NoteType.tie if tie else
                      M.NoteType.normal, velocity=_velocity(el))
        _effects(M, note, beat, el, tuning)
        g = pending_grace.pop((k, v, s), None)
        if g is not None:
            note.effect.grace = M.GraceEffect(duration=32, fret=g[0], isOnBeat=False,
                                              transition=M.GraceEffectTransition.none)
        beat.notes.append(note)
    for voice in voices.values():
        voice.beats.sort(key=lambda b: b.start)
    return track


def _velocity(el) -> int:
    dyn = el.get("dynamics")
    if dyn is None:
        return 95
    return int(min(max(_f(dyn, 100.0) / 100.0 * 95, 1), 127))


def _assign(events, tuning, track, warnings) -> dict[int, tuple]:
    """{event index: (string, fret, tied)}: the note's tablature, else the fingering over the
    part; a tied note continues the position of the note it is tied from."""
    placed: dict[int, tuple] = {}
    free = []
    tie_stop = [any(t.get("type") == "stop" for t in e[4].findall("tie")) for e in events]
    for i, (_k, _v, _tick, _dur, el, pitch, _grace) in enumerate(events):
        s = _t(el, "notations/technical/string")
        f = _t(el, "notations/technical/fret")
        if s and f and 1 <= int(_f(s)) <= len(tuning):
            placed[i] = (int(_f(s)), int(_f(f)), tie_stop[i])
        elif pitch is not None and not tie_stop[i]:
            free.append(i)
    if free:
        spq = 0.5 / Q  # seconds per tick at 120 quarter notes a minute
        times = [float(events[i][2]) * spq for i in free]
        ends = [float(events[i][2] + max(events[i][3], 1)) * spq for i in free]
        pitches = [events[i][5] for i in free]
        fing = fingering.viterbi(times, ends, pitches, tuning, 24)
        for j, i in enumerate(free):
            where = f"bar {events[i][0] + 1}, beat 1, track '{track.name}' ({track.number})"
            if j in fing.dropped or fing.position[j] is None:
                warnings.append(f"{where}: note {C.midi_name(pitches[j])} left out (no string "
                                "free or within the hand's reach in this chord)")
                continue
            if j in fing.moved:
                warnings.append(f"{where}: note {C.midi_name(pitches[j])} outside the "
                                f"instrument's range, played as {C.midi_name(fing.pitch[j])}")
            s, f = fing.position[j]
            placed[i] = (s, f, False)
    last: dict[tuple, tuple] = {}  # (voice, pitch) -> position of the latest note
    for i, (_k, v, _tick, _dur, _el, pitch, _grace) in enumerate(events):
        if i in placed:
            last[(v, pitch)] = placed[i]
        elif tie_stop[i] and (v, pitch) in last:
            s0, f0, _ = last[(v, pitch)]
            placed[i] = (s0, f0, True)
    return placed


def _effects(M, note, beat, el, tuning):
    eff = note.effect
    tech = el.find("notations/technical")
    notations = el.find("notations")
    if tech is not None:
        if tech.find("hammer-on") is not None and tech.find("hammer-on").get("type") == "start" \
                or tech.find("pull-off") is not None and tech.find("pull-off").get("type") == "start":
            eff.hammer = True
        b = tech.find("bend")
        if b is not None:
            alter = _f(_t(b, "bend-alter"), 1.0)
            qt = abs(alter) * 2
            if b.find("pre-bend") is not None:
                pts = [(0, qt), (12, qt)]
            elif b.find("release") is not None:
                pts = [(0, 0), (3, qt), (6, qt), (9, 0), (12, 0)]
            else:
                pts = [(0, 0), (6, qt), (12, qt)]
            eff.bend = M.BendEffect(points=[M.BendPoint(position=p, value=v) for p, v in pts])
        h = tech.find("harmonic")
        if h is not None:
            eff.harmonic = M.ArtificialHarmonic() if h.find("artificial") is not None else \
                M.NaturalHarmonic()
        if tech.find("tap") is not None:
            beat.effect.slapEffect = M.SlapEffect.tapping
        for ot in tech.findall("other-technical"):
            if (ot.text or "").strip().lower().replace(".", "") in ("palm mute", "pm"):
                eff.palmMute = True
    if notations is not None:
        for sl in list(notations.findall("slide")) + list(notations.findall("glissando")):
            if sl.get("type") == "start":
                eff.slides = [M.SlideType.legatoSlideTo]
        art = notations.find("articulations")
        if art is not None:
            eff.staccato = art.find("staccato") is not None
            eff.accentuatedNote = art.find("accent") is not None
            eff.heavyAccentuatedNote = art.find("strong-accent") is not None
        orn = notations.find("ornaments")
        if orn is not None:
            if orn.find("wavy-line") is not None or orn.find("vibrato") is not None:
                eff.vibrato = True
            trem = orn.find("tremolo")
            if trem is not None and trem.get("type", "single") == "single":
                marks = int(_f(trem.text, 3))
                eff.tremoloPicking = M.TremoloPickingEffect(
                    M.Duration(value={1: 8, 2: 16}.get(marks, 32)))
        arp = notations.find("arpeggiate")
        if arp is not None:
            # MusicXML "up" (the default): lowest note first, a guitarist's down stroke
            high_first = arp.get("direction") == "down"
            beat.effect.stroke = M.BeatStroke(direction=M.BeatStrokeDirection.up if high_first
                                              else M.BeatStrokeDirection.down, value=16)
    if _t(el, "notehead") == "x":
        note.type = M.NoteType.dead


def parse_song(data: bytes, warnings: list[str]):
    xml = unpack(data)
    if len(xml) > MAX_GPIF_BYTES:
        raise ScoreError(f"MusicXML score is larger than {MAX_GPIF_BYTES} bytes")
    n = xml.count(b"<note>") + xml.count(b"<note ")
    if n > C.MAX_NOTES:
        raise ScoreError(f"MusicXML score has {n} notes (allowed at most {C.MAX_NOTES})")
    root = parse_xml(xml, "MusicXML score", allow_doctype=True)
    try:
        return to_song(root, warnings)
    except ScoreError:
        raise
    except (ValueError, TypeError, KeyError, IndexError, AttributeError, ZeroDivisionError) as exc:
        raise ScoreError(f"MusicXML score is malformed: {type(exc).__name__}: {exc}"[:300]) \
            from None


_HARMONY_KINDS = {
    "major": "maj", "minor": "min", "augmented": "aug", "diminished": "dim", "dominant": "7",
    "major-seventh": "maj7", "minor-seventh": "min7", "diminished-seventh": "dim7",
    "augmented-seventh": "aug7", "half-diminished": "hdim7", "major-minor": "minmaj7",
    "major-sixth": "maj6", "minor-sixth": "min6", "dominant-ninth": "9", "major-ninth": "maj9",
    "minor-ninth": "min9", "dominant-11th": "11", "major-11th": "maj11", "minor-11th": "min11",
    "dominant-13th": "13", "major-13th": "maj13", "minor-13th": "min13",
    "suspended-second": "sus2", "suspended-fourth": "sus4", "power": "5"}


def _harmony(el) -> str | None:
    """A ``<harmony>`` chord symbol in JAMS ``chord`` syntax ('Bb:min7', 'C:maj/3'); None for a
    kind JAMS has no name for (or 'none')."""
    from .gp import _DEGREES, _NAMES

    step = _t(el, "root/root-step")
    quality = _HARMONY_KINDS.get(_t(el, "kind"))
    if step not in _STEPS or quality is None:
        return None
    root = (_STEPS[step] + int(_f(_t(el, "root/root-alter"), 0))) % 12
    out = f"{_NAMES[root]}:{quality}"
    bass = _t(el, "bass/bass-step")
    if bass in _STEPS:
        b = (_STEPS[bass] + int(_f(_t(el, "bass/bass-alter"), 0))) % 12
        if b != root:
            out += "/" + _DEGREES[(b - root) % 12]
    return out
