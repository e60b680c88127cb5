"""Guitar Pro 6 (``.gpx``) and Guitar Pro 7/8 (``.gp``) -> PyGuitarPro's song model.

Both formats hold one XML document, ``score.gpif`` (GPIF): a ``.gpx`` file is a BCFS container
(4096-byte sectors, a file table), usually BCFZ-compressed (a bit-level LZ77); a ``.gp`` file is a
zip archive holding ``Content/score.gpif``.  ``unpack`` takes the document out of either, with every
length checked before anything is allocated (``MAX_GPIF_BYTES``), and ``to_song`` builds from it
the ``guitarpro.models.Song`` a Guitar Pro 3-5 file of the same song reads as.  ``gp.convert`` then
maps that song to a scene, so the effects, timing, repeats and warnings of every Guitar Pro
version come from one place and the same song in any version gives the same scene.

GPIF keeps its objects in id-indexed tables (MasterBars -> Bars -> Voices -> Beats -> Notes, and
Rhythms), shared between references; ``to_song`` walks them in playing order.  What maps to what:

* **MasterBar**: time signature, repeat start/end (``count`` = times played), alternate endings,
  directions (Segno, Coda, Fine, D.C./D.S. al ...), triplet feel -> ``MeasureHeader``.
* **Track**: name, tuning (``Pitches``, lowest string first; string 0 is the lowest), capo, the
  General MIDI program (Guitar Pro 6 ``GeneralMidi``, 7/8 ``Sounds``), percussion (drum kit).
* **Tempo automations** of the master track -> the song's tempo and mix-table tempo changes at the
  beat nearest their position in the bar.
* **Beat**: rhythm (note value, dots, tuplet), grace notes (a beat before the main one, which takes
  no time of the bar), dynamics, tremolo picking, brush (strum) and its direction, slap/pop,
  rasgueado, whammy bar, fade-in, wide vibrato.
* **Note**: string, fret, tie, dead (``Muted``), palm mute, let ring, ghost, accents, staccato,
  vibrato, hammer-on/pull-off origin, slides (shift, legato, out down/up, in from below/above),
  harmonics (natural, artificial, pinch, tapped, semi), bends (origin, middle, destination
  values and offsets: GPIF value 100 = a whole tone), trill (its other note as a MIDI pitch),
  tapping.

XML is parsed with ``defusedxml`` (no DTDs, no entity expansion).
"""

from __future__ import annotations

import io
import re
import zipfile

from . import common as C
from .common import ScoreError

MAX_GPIF_BYTES = 32 * 1024 * 1024  # the unpacked score.gpif (real files: well under 5 MB)
MAX_CONTAINER_BYTES = 64 * 1024 * 1024  # a BCFZ container's declared unpacked size
_SECTOR = 0x1000
_DYNAMICS = {"PPP": 15, "PP": 31, "P": 47, "MP": 63, "MF": 79, "F": 95, "FF": 111, "FFF": 127}
_NOTE_VALUES = {"Long": 1, "DoubleWhole": 1, "Whole": 1, "Half": 2, "Quarter": 4, "Eighth": 8,
                "16th": 16, "32nd": 32, "64th": 64, "128th": 128, "256th": 128}


def sniff(data: bytes) -> str | None:
    """'gpx' for a BCFZ/BCFS container, 'gp7' for a zip holding Content/score.gpif, else None."""
    if data[:4] in (b"BCFZ", b"BCFS"):
        return "gpx"
    if data[:4] == b"PK\x03\x04" and b"Content/score.gpif" in data[:1 << 20] + data[-(1 << 16):]:
        return "gp7"
    return None


# --- containers --------------------------------------------------------------------------------

def _bcfz(data: bytes) -> bytes:
    """BCFZ: a little-endian unpacked length, then bits (most significant first): 1 -> a copy
    (4-bit word size w, then offset back and length, w bits each, least significant first),
    0 -> 2-bit count (least significant first) of literal bytes."""
    if len(data) < 8:
        raise ScoreError("Guitar Pro 6 file is truncated: no BCFZ length")
    expected = int.from_bytes(data[4:8], "little")
    if not 0 < expected <= MAX_CONTAINER_BYTES:
        raise ScoreError(f"Guitar Pro 6 container declares {expected} unpacked bytes "
                         f"(allowed 1..{MAX_CONTAINER_BYTES})")
    buf = data[8:]
    nbits = len(buf) * 8
    out = bytearray()
    pos = 0

    def bits(n: int) -> int:
        nonlocal pos
        if pos + n > nbits:
            raise EOFError
        v = 0
        for _ in range(n):
            v = (v << 1) | ((buf[pos >> 3] >> (7 - (pos & 7))) & 1)
            pos += 1
        return v

    def bits_rev(n: int) -> int:
        nonlocal pos
        if pos + n > nbits:
            raise EOFError
        v = 0
        for i in range(n):
            v |= ((buf[pos >> 3] >> (7 - (pos & 7))) & 1) << i
            pos += 1
        return v

    try:
        while len(out) < expected:
            if bits(1):
                w = bits(4)
                offset = bits_rev(w)
                size = bits_rev(w)
                src = len(out) - offset
                if offset == 0 or src < 0:
                    raise ScoreError("Guitar Pro 6 file is corrupt: a BCFZ copy reaches before "
                                     "the start of the data")
                out += out[src:src + min(offset, size)]
            else:
                for _ in range(bits_rev(2)):
                    out.append(bits(8))
    except EOFError:
        pass  # the stream may end before the declared length (the reader's rule)
    return bytes(out[:expected])


def _bcfs(data: bytes, want: str = "score.gpif") -> bytes:
    """The file ``want`` of a BCFS container (``data`` starts after its 'BCFS' magic)."""
    n = len(data)

    def i32(off: int) -> int:
        if off + 4 > n:
            raise ScoreError("Guitar Pro 6 container is truncated (a file table entry runs past "
                             "its end)")
        return int.from_bytes(data[off:off + 4], "little")

    offset = _SECTOR
    while offset + 3 < n:
        if i32(offset) == 2:
            name = data[offset + 4:offset + 4 + 127].split(b"\0", 1)[0].decode("latin-1")
            size = i32(offset + 0x8C)
            if size > MAX_GPIF_BYTES and name == want:
                raise ScoreError(f"Guitar Pro 6 file declares a {size}-byte score (the limit is "
                                 f"{MAX_GPIF_BYTES})")
            chunks = []
            ptr = offset + 0x94
            got = 0
            while True:
                sector = i32(ptr)
                ptr += 4
                if sector == 0:
                    break
                offset = sector * _SECTOR
                if offset >= n:
                    raise ScoreError("Guitar Pro 6 container is truncated (a sector lies past "
                                     "its end)")
                if name == want:
                    chunks.append(data[offset:offset + _SECTOR])
                    got += _SECTOR
                    if got > MAX_GPIF_BYTES + _SECTOR:
                        raise ScoreError("Guitar Pro 6 score is larger than the limit of "
                                         f"{MAX_GPIF_BYTES} bytes")
            if name == want:
                return b"".join(chunks)[:size]
        offset += _SECTOR
    raise ScoreError(f"Guitar Pro 6 container holds no {want}")


def unpack(data: bytes) -> bytes:
    """The ``score.gpif`` document of a .gpx or .gp file's bytes."""
    head = data[:4]
    if head == b"BCFZ":
        inner = _bcfz(data)
        if inner[:4] != b"BCFS":
            raise ScoreError("Guitar Pro 6 file is corrupt: the unpacked BCFZ data is not a "
                             "BCFS container")
        return _bcfs(inner[4:])
    if head == b"BCFS":
        return _bcfs(data[4:])
    if head == b"PK\x03\x04":
        return zip_member(data, _gpif_member, "Guitar Pro 7 file")
    raise ScoreError(f"not a Guitar Pro 6/7/8 file (unknown header {head!r})")


def _gpif_member(zf: zipfile.ZipFile) -> zipfile.ZipInfo:
    info = next((i for i in zf.infolist() if i.filename.lower() == "content/score.gpif"), None)
    if info is None:
        raise ScoreError("a zip archive without Content/score.gpif: not a Guitar Pro 7/8 file")
    return info


def zip_member(data: bytes, choose, what: str) -> bytes:
    """The member of a zip archive that ``choose(zipfile)`` picks (it raises ``ScoreError`` when
    there is none), read with both its declared and its real size bounded by ``MAX_GPIF_BYTES``
    (a zip bomb stops there); ``what`` names the file in each refusal."""
    try:
        zf = zipfile.ZipFile(io.BytesIO(data))
        info = choose(zf)
        if info.file_size > MAX_GPIF_BYTES:
            raise ScoreError(f"{what} declares a {info.file_size}-byte score (the limit is "
                             f"{MAX_GPIF_BYTES})")
        with zf.open(info) as f:
            xml = f.read(MAX_GPIF_BYTES + 1)
    except ScoreError:
        raise
    except Exception as exc:  # BadZipFile, zlib.error, NotImplementedError (method), EOF
        msg = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ScoreError(f"{what} (zip) is truncated or corrupt: {msg}"[:300]) from None
    if len(xml) > MAX_GPIF_BYTES:
        raise ScoreError(f"{what}: its score unpacks to more than {MAX_GPIF_BYTES} bytes")
    return xml


def parse_xml(xml: bytes, what: str, allow_doctype: bool = False):
    """An ElementTree root of untrusted XML: entity declarations and external references
    refused, and a DOCTYPE too unless ``allow_doctype`` (MusicXML files name their DTD; it is
    never fetched)."""
    from xml.etree.ElementTree import ParseError

    import defusedxml.ElementTree as DET
    from defusedxml import DefusedXmlException

    try:
        return DET.fromstring(xml, forbid_dtd=not allow_doctype, forbid_entities=True,
                              forbid_external=True)
    except DefusedXmlException as exc:
        raise ScoreError(f"{what} refused: {type(exc).__name__} (entity declarations, external "
                         "references" + ("" if allow_doctype else " and DTDs") + " are not "
                         "accepted)") from None
    except ParseError as exc:
        raise ScoreError(f"{what} is not well-formed XML: {exc}"[:300]) from None


# --- GPIF -> song --------------------------------------------------------------------------------

def _text(el, path: str, default: str = "") -> str:
    if el is None:
        return default
    x = el.find(path)
    return (x.text or "").strip() if x is not None and x.text is not None else default


def _ints(s: str) -> list[int]:
    out = []
    for tok in s.split():
        try:
            out.append(int(tok))
        except ValueError:
            continue
    return out


def _num(s: str, default: float = 0.0) -> float:
    try:
        return float(s)
    except (TypeError, ValueError):
        return default


def _props(el) -> dict:
    """{Property name: Property element} of ``el/Properties``."""
    p = el.find("Properties") if el is not None else None
    return {x.get("name"): x for x in p.findall("Property")} if p is not None else {}


def _table(root, section: str, child: str, limit: int, what: str) -> dict:
    sec = root.find(section)
    if sec is None:
        return {}
    items = sec.findall(child)
    if len(items) > limit:
        raise ScoreError(f"Guitar Pro file has {len(items)} {what} (allowed at most {limit})")
    return {x.get("id"): x for x in items}


def _words(camel: str) -> str:
    """'DaSegnoSegnoAlDoubleCoda' -> 'Da Segno Segno al Double Coda' (PyGuitarPro's names)."""
    return " ".join(re.findall(r"[A-Z][a-z]*", camel)).replace(" Al ", " al ")


def _duration(rhythm, M):
    value = _NOTE_VALUES.get(_text(rhythm, "NoteValue"), 4)
    dots = 0
    dot = rhythm.find("AugmentationDot") if rhythm is not None else None
    if dot is not None:
        dots = int(_num(dot.get("count"), 1))
    enters, times = 1, 1
    tup = rhythm.find("PrimaryTuplet") if rhythm is not None else None
    if tup is not None:
        num, den = int(_num(tup.get("num"), 1)), int(_num(tup.get("den"), 1))
        if 1 <= num <= 64 and 1 <= den <= 64:
            enters, times = num, den
    if dots >= 2:  # 1 + 1/2 + 1/4 = 7/4: as a tuplet, which PyGuitarPro's time applies
        enters, times = enters * 4, times * 7
    return M.Duration(value=value, isDotted=dots == 1, tuplet=M.Tuplet(enters=enters, times=times))


class _Builder:
    def __init__(self, root, warnings: list[str]):
        import guitarpro.models as M

        self.M = M
        self.root = root
        self.warnings = warnings
        self.rhythms = _table(root, "Rhythms", "Rhythm", C.MAX_BEATS, "rhythms")
        self.notes = _table(root, "Notes", "Note", C.MAX_NOTES, "notes")
        self.beats = _table(root, "Beats", "Beat", C.MAX_BEATS, "beats")
        self.voices = _table(root, "Voices", "Voice", C.MAX_BEATS, "voices")
        self.bars = _table(root, "Bars", "Bar", C.MAX_MEASURES * C.MAX_TRACKS, "bars")
        self.beat_count = 0
        self.chords: dict[str, str] = {}  # the current track's chord diagrams: id -> name

    def song(self):
        M, root = self.M, self.root
        score = root.find("Score")
        song = M.Song(title=_text(score, "Title"), subtitle=_text(score, "SubTitle"),
                      artist=_text(score, "Artist"), album=_text(score, "Album"))
        masters = root.find("MasterBars")
        masters = masters.findall("MasterBar") if masters is not None else []
        if not 0 < len(masters) <= C.MAX_MEASURES:
            raise ScoreError(f"Guitar Pro file has {len(masters)} bars (allowed 1..{C.MAX_MEASURES})")
        track_els = root.find("Tracks")
        track_els = track_els.findall("Track") if track_els is not None else []
        if not 0 < len(track_els) <= C.MAX_TRACKS:
            raise ScoreError(f"Guitar Pro file has {len(track_els)} tracks "
                             f"(allowed 1..{C.MAX_TRACKS})")
        headers = []
        start = M.Duration.quarterTime
        for k, mb in enumerate(masters):
            h = self._header(mb, k + 1, start)
            headers.append(h)
            start += h.length
        song.measureHeaders = headers
        tempos = self._tempos(len(headers))
        if tempos.get(0) and tempos[0][0][0] == 0:
            song.tempo = tempos[0][0][1]
        staves = [max(len(t.findall("Staves/Staff")), 1) for t in track_els]
        bar_lists = [_ints(_text(mb, "Bars")) for mb in masters]
        if bar_lists and len(bar_lists[0]) != sum(staves):
            staves = [1] * len(track_els)
        first = [sum(staves[:i]) for i in range(len(track_els))]
        song.tracks = []
        for i, t_el in enumerate(track_els):
            song.tracks.append(self._track(song, t_el, i + 1, headers, bar_lists, first[i]))
        self._place_tempos(song, tempos)
        return song

    def _header(self, mb, number: int, start: int):
        M = self.M
        num, _, den = _text(mb, "Time", "4/4").partition("/")
        num_i, den_i = int(_num(num, 4)), int(_num(den, 4))
        if not 1 <= num_i <= 128 or den_i not in (1, 2, 4, 8, 16, 32, 64, 128):
            raise ScoreError(f"bar {number}: time signature {num}/{den} not readable")
        h = M.MeasureHeader(number=number, start=start, timeSignature=M.TimeSignature(
            numerator=num_i, denominator=M.Duration(value=den_i)))
        rep = mb.find("Repeat")
        if rep is not None:
            h.isRepeatOpen = rep.get("start", "").lower() == "true"
            if rep.get("end", "").lower() == "true":
                h.repeatClose = max(int(_num(rep.get("count"), 2)) - 1, 0)
        alt = 0
        for e in _ints(_text(mb, "AlternateEndings")):
            if 1 <= e <= 8:
                alt |= 1 << (e - 1)
        h.repeatAlternative = alt
        key = mb.find("Key")
        if key is not None:  # (accidentals, minor) as PyGuitarPro's key signatures
            acc = int(_num(_text(key, "AccidentalCount"), 0))
            try:
                h.keySignature = M.KeySignature((acc, int(_text(key, "Mode") == "Minor")))
            except ValueError:
                pass
        feel = _text(mb, "TripletFeel")
        if feel in ("Triplet8th", "Triplet16th"):
            h.tripletFeel = M.TripletFeel.eighth if feel == "Triplet8th" else M.TripletFeel.sixteenth
        elif feel and feel != "NoTripletFeel":
            self.warnings.append(f"bar {number}, beat 1, track all: {feel} feel played straight")
        d = mb.find("Directions")
        if d is not None:
            target, jump = _text(d, "Target"), _text(d, "Jump")
            if target:
                h.direction = M.DirectionSign(_words(target))
            if jump:
                h.fromDirection = M.DirectionSign(_words(jump))
        return h

    def _tempos(self, n_bars: int) -> dict[int, list[tuple[float, float]]]:
        """{bar index: [(position 0..1 in the bar, quarter notes per minute)]}"""
        out: dict[int, list[tuple[float, float]]] = {}
        autos = self.root.find("MasterTrack/Automations")
        for a in autos.findall("Automation") if autos is not None else []:
            if _text(a, "Type") != "Tempo":
                continue
            parts = _text(a, "Value").split()
            bpm = _num(parts[0] if parts else "", 0.0)
            ref = int(_num(parts[1], 2)) if len(parts) > 1 else 2
            bpm *= {1: 0.5, 2: 1.0, 3: 1.5, 4: 2.0, 5: 3.0}.get(ref, 1.0)
            bar = int(_num(_text(a, "Bar"), 0))
            if not 1.0 <= bpm <= 1000.0 or not 0 <= bar < n_bars:
                self.warnings.append(f"bar {bar + 1}, beat 1, track all: tempo {bpm:g} ignored "
                                     "(outside 1..1000 or the score)")
                continue
            pos = min(max(_num(_text(a, "Position"), 0.0), 0.0), 1.0)
            out.setdefault(bar, []).append((pos, bpm))
            if _text(a, "Linear").lower() == "true":
                self.warnings.append(f"bar {bar + 1}, beat 1, track all: gradual tempo change "
                                     "played as a step")
        return out

    def _place_tempos(self, song, tempos):
        """Tempo changes as mix-table changes on the first track's beats (``gp._Clock`` reads
        them from any track, at the beat's position)."""
        M = self.M
        if not song.tracks:
            return
        track = song.tracks[0]
        for bar, items in tempos.items():
            measure = track.measures[bar]
            h = measure.header
            for pos, bpm in items:
                if bar == 0 and pos == 0 and bpm == song.tempo:
                    continue
                tick = h.start + round(pos * h.length)
                voice = measure.voices[0]
                beat = next((b for b in voice.beats if b.start == tick), None)
                if beat is None or beat.effect.mixTableChange is not None:
                    beat = M.Beat(voice, start=tick, status=M.BeatStatus.empty)
                    voice.beats.append(beat)
                beat.effect.mixTableChange = M.MixTableChange(tempo=M.MixTableItem(value=bpm))

    def _track(self, song, t_el, number: int, headers, bar_lists, staff_index: int):
        M = self.M
        name = _text(t_el, "Name") or f"Track {number}"
        props = _props(t_el)
        staff = t_el.find("Staves/Staff")
        if staff is not None:
            props = {**props, **_props(staff)}
        diagrams = props.get("DiagramCollection")
        self.chords = {i.get("id"): i.get("name") or "" for i in (
            diagrams.findall("Items/Item") if diagrams is not None else [])}
        tuning = _ints(_text(props.get("Tuning"), "Pitches"))
        capo = int(_num(_text(props.get("CapoFret"), "Fret"), 0))
        program = None
        for path in ("GeneralMidi/Program", "Sounds/Sound/MIDI/Program", "MidiConnection/Program"):
            if t_el.find(path) is not None:
                program = int(_num(_text(t_el, path), 25))
                break
        inst = (t_el.find("Instrument").get("ref", "") if t_el.find("Instrument") is not None
                else "") + " " + _text(t_el, "InstrumentSet/Type")
        channel = int(_num(_text(t_el, "GeneralMidi/PrimaryChannel"), -1))
        if channel < 0:
            channel = int(_num(_text(t_el, "MidiConnection/PrimaryChannel"), 0))
        drums = channel == 9 or "drum" in inst.lower() or "drmkt" in inst.lower() or \
            _text(t_el, "InstrumentSet/Type").lower() == "drumkit"
        if program is None:
            program = 33 if "bass" in inst.lower() else 25
        if not tuning and not drums:
            tuning = []  # an instrument without strings (piano, voice): no tab to play
        n = len(tuning)
        strings = [M.GuitarString(number=k + 1, value=p) for k, p in enumerate(reversed(tuning))]
        track = M.Track(song, number=number, name=name, offset=max(capo, 0),
                        isPercussionTrack=drums, strings=strings,
                        channel=M.MidiChannel(channel=max(channel, 0), instrument=program))
        track.measures = []
        for k, h in enumerate(headers):
            measure = M.Measure(track, h)
            measure.voices = []
            ids = bar_lists[k]
            bar = self.bars.get(str(ids[staff_index])) if staff_index < len(ids) else None
            vids = _ints(_text(bar, "Voices")) if bar is not None else []
            for vid in [v for v in vids if v >= 0][:4] or [-1]:
                voice = M.Voice(measure)
                voice.beats = []
                if vid >= 0:
                    self._voice(voice, self.voices.get(str(vid)), h, n, tuning)
                measure.voices.append(voice)
            track.measures.append(measure)
        return track

    def _voice(self, voice, v_el, header, n_strings: int, tuning: list[int]):
        M = self.M
        ids = _ints(_text(v_el, "Beats")) if v_el is not None else []
        if len(ids) > 1024:
            raise ScoreError(f"bar {header.number}: {len(ids)} beats in one voice (allowed 0..1024)")
        tick = header.start
        graces = []
        for bid in ids:
            b_el = self.beats.get(str(bid))
            if b_el is None:
                continue
            self.beat_count += 1
            if self.beat_count > C.MAX_BEATS:
                raise ScoreError(f"Guitar Pro file has more than {C.MAX_BEATS} beats")
            dur = _duration(self.rhythms.get(b_el.find("Rhythm").get("ref")
                                              if b_el.find("Rhythm") is not None else None), M)
            note_els = [self.notes.get(str(i)) for i in _ints(_text(b_el, "Notes"))]
            note_els = [x for x in note_els if x is not None]
            if b_el.find("GraceNotes") is not None:
                graces.append((b_el, dur, note_els))
                continue
            beat = M.Beat(voice, start=tick, duration=dur,
                          status=M.BeatStatus.normal if note_els else M.BeatStatus.rest)
            name = self.chords.get(_text(b_el, "Chord") or None)
            if name:  # a chord diagram's name (gp.chord_name reads it)
                beat.effect.chord = M.Chord(n_strings, name=name)
            velocity = _DYNAMICS.get(_text(b_el, "Dynamic"), 95)
            self._beat_effects(beat, b_el, dur)
            for n_el in note_els:
                note = self._note(beat, n_el, velocity, n_strings, tuning)
                if note is not None:
                    beat.notes.append(note)
            if _text(b_el, "Tremolo") and beat.notes:
                value = {"1/2": 8, "1/4": 16, "1/8": 32}.get(_text(b_el, "Tremolo"), 16)
                for note in beat.notes:
                    note.effect.tremoloPicking = M.TremoloPickingEffect(M.Duration(value=value))
            if graces:
                self._graces(beat, graces, n_strings)
                graces = []
            voice.beats.append(beat)
            tick += dur.time

    def _beat_effects(self, beat, b_el, dur):
        M = self.M
        be = beat.effect
        props = _props(b_el)
        if "Brush" in props:
            up = _text(props["Brush"], "Direction") == "Up"
            # its length: XProperty 687935489, in GPIF ticks (480 a quarter) -> the note value
            ticks = 0.0
            for xp in b_el.findall("XProperties/XProperty"):
                if xp.get("id") == "687935489":
                    ticks = _num(_text(xp, "Int"), 0.0)
            value = min(max(round(1920.0 / ticks), 1), 128) if ticks > 0 else 0
            be.stroke = M.BeatStroke(direction=M.BeatStrokeDirection.up if up
                                     else M.BeatStrokeDirection.down, value=value)
        if "Slapped" in props:
            be.slapEffect = M.SlapEffect.slapping
        elif "Popped" in props:
            be.slapEffect = M.SlapEffect.popping
        if "Rasgueado" in props:
            be.hasRasgueado = True
        if "WhammyBar" in props:
            be.tremoloBar = M.BendEffect(points=[M.BendPoint(0, 0), M.BendPoint(12, 0)])
        if "VibratoWTremBar" in props:
            be.vibrato = True
        if _text(b_el, "Fadding") == "FadeIn":
            be.fadeIn = True

    def _note(self, beat, n_el, velocity: int, n_strings: int, tuning: list[int]):
        M = self.M
        props = _props(n_el)
        s = int(_num(_text(props.get("String"), "String"), -1))
        fret = int(_num(_text(props.get("Fret"), "Fret"), 0))
        string = n_strings - s if 0 <= s < n_strings else 0
        note = M.Note(beat, value=fret, velocity=velocity, string=string, type=M.NoteType.normal)
        eff = note.effect
        tie = n_el.find("Tie")
        if tie is not None and tie.get("destination", "").lower() == "true":
            note.type = M.NoteType.tie
        if "Muted" in props:
            note.type = M.NoteType.dead
        eff.palmMute = "PalmMuted" in props
        eff.letRing = n_el.find("LetRing") is not None
        eff.ghostNote = _text(n_el, "AntiAccent").lower() == "normal"
        acc = int(_num(_text(n_el, "Accent"), 0))
        eff.staccato = bool(acc & 1)
        eff.heavyAccentuatedNote = bool(acc & 4)
        eff.accentuatedNote = bool(acc & 8)
        vib = _text(n_el, "Vibrato")
        if vib:
            eff.vibrato = True
            if vib == "Wide":
                beat.effect.vibrato = True
        eff.hammer = "HopoOrigin" in props
        if "Tapped" in props or "LeftHandTapped" in props:
            beat.effect.slapEffect = M.SlapEffect.tapping
        flags = int(_num(_text(props.get("Slide"), "Flags"), 0))
        slides = []
        for bit, kind in ((1, "shiftSlideTo"), (2, "legatoSlideTo"), (4, "outDownwards"),
                          (8, "outUpwards"), (16, "intoFromBelow"), (32, "intoFromAbove"),
                          (64, "outDownwards"), (128, "outUpwards")):
            if flags & bit and getattr(M.SlideType, kind) not in slides:
                slides.append(getattr(M.SlideType, kind))
        eff.slides = slides
        htype = _text(props.get("HarmonicType"), "HType")
        if htype and htype != "NoHarmonic":
            hfret = _num(_text(props.get("HarmonicFret"), "HFret"), 12.0)
            eff.harmonic = {
                "Natural": lambda: M.NaturalHarmonic(),
                "Artificial": lambda: M.ArtificialHarmonic(),
                "Pinch": lambda: M.PinchHarmonic(),
                "Tap": lambda: M.TappedHarmonic(fret=round(fret + hfret)),
                "Semi": lambda: M.SemiHarmonic(),
                "Feedback": lambda: M.SemiHarmonic(),
            }.get(htype, lambda: M.SemiHarmonic())()
        if "Bended" in props:
            eff.bend = self._bend(props)
        trill = _text(n_el, "Trill")
        if trill and string:
            open_pitch = tuning[s] if 0 <= s < len(tuning) else 0
            eff.trill = M.TrillEffect(fret=int(_num(trill, 0)) - open_pitch,
                                      duration=M.Duration(value=16))
        return note

    def _bend(self, props):
        """GPIF's bend (origin, middle, destination: value 100 = a whole tone, offset 0..100 of
        the note) as PyGuitarPro's points (value in quarter tones, position 0..12)."""
        M = self.M

        def f(name, default=None):
            el = props.get(name)
            return _num(_text(el, "Float"), default) if el is not None else default

        pts = [(f("BendOriginOffset", 0.0), f("BendOriginValue", 0.0))]
        mid = f("BendMiddleValue")
        o1, o2 = f("BendMiddleOffset1"), f("BendMiddleOffset2")
        if mid is not None:
            if o1:
                pts.append((o1, mid))
            if o2:
                pts.append((o2, mid))
            if not o1 and not o2:
                pts.append((50.0, mid))
        pts.append((f("BendDestinationOffset", 100.0), f("BendDestinationValue", 0.0)))
        pts.sort(key=lambda p: p[0])
        return M.BendEffect(points=[M.BendPoint(position=min(max(o, 0.0), 100.0) * 0.12,
                                                value=v / 25.0) for o, v in pts])

    def _graces(self, beat, graces, n_strings: int):
        """Grace beats before ``beat`` -> a ``GraceEffect`` on the note of the same string (the
        last grace on each string, as Guitar Pro 3-5 holds one grace per note)."""
        M = self.M
        by_string = {n.string: n for n in beat.notes}
        for b_el, dur, note_els in graces:
            on_beat = _text(b_el, "GraceNotes") == "OnBeat"
            velocity = _DYNAMICS.get(_text(b_el, "Dynamic"), 95)
            for n_el in note_els:
                props = _props(n_el)
                s = int(_num(_text(props.get("String"), "String"), -1))
                string = n_strings - s if 0 <= s < n_strings else 0
                target = by_string.get(string)
                if target is None:
                    continue
                flags = int(_num(_text(props.get("Slide"), "Flags"), 0))
                trans = M.GraceEffectTransition.none
                if flags & 3:
                    trans = M.GraceEffectTransition.slide
                elif "HopoOrigin" in props:
                    trans = M.GraceEffectTransition.hammer
                elif "Bended" in props:
                    trans = M.GraceEffectTransition.bend
                target.effect.grace = M.GraceEffect(
                    duration=min(max(dur.value, 1), 128),
                    fret=int(_num(_text(props.get("Fret"), "Fret"), 0)),
                    isDead="Muted" in props, isOnBeat=on_beat, transition=trans,
                    velocity=velocity)


def to_song(root, warnings: list[str]):
    """PyGuitarPro's ``Song`` of a GPIF document's root element."""
    if root.tag != "GPIF":
        raise ScoreError(f"not a Guitar Pro 6/7/8 score: its XML root is <{root.tag}>, not <GPIF>")
    try:
        return _Builder(root, warnings).song()
    except ScoreError:
        raise
    except (ValueError, TypeError, KeyError, IndexError, AttributeError) as exc:
        raise ScoreError(f"Guitar Pro 6/7/8 score is malformed: {type(exc).__name__}: {exc}"[:300]) \
            from None


def parse_song(data: bytes, warnings: list[str]):
    """PyGuitarPro's ``Song`` of a .gpx or .gp file's bytes."""
    xml = unpack(data)
    if not xml.strip():
        raise ScoreError("Guitar Pro 6/7/8 file holds an empty score.gpif")
    # counted in the bytes before a tree is built: a hostile document costs no element objects
    for tag, limit, what in ((b"<MasterBar", C.MAX_MEASURES, "bars"),
                             (b"<Note", C.MAX_NOTES, "notes"), (b"<Beat", C.MAX_BEATS, "beats")):
        n = xml.count(tag + b" ") + xml.count(tag + b">")
        if n > limit:
            raise ScoreError(f"Guitar Pro file has {n} {what} (allowed at most {limit})")
    return to_song(parse_xml(xml, "Guitar Pro score.gpif"), warnings)
