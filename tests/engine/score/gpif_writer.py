"""Write a PyGuitarPro song as Guitar Pro 6/7 files, for the tests: the GPIF document (the XML
Guitar Pro 6-8 save), packed as a .gp zip, an uncompressed BCFS container or a BCFZ-compressed one.

No registry (PyPI, Debian, npm) ships .gpx/.gp files, so the committed tests build them from the
third-party .gp5 files of PyGuitarPro's corpus with this writer, then check that reading them back
gives the .gp5's scene.  The writer follows the format as Guitar Pro writes it (alphaTab's
GpifWriter and Guitar Pro's own files were read for it); what it cannot express (bend curves of
more than three shapes, RSE note lengths) is left out, and the tests pick files without those.
"""

from __future__ import annotations

import io
import zipfile

_VALUES = {1: "Whole", 2: "Half", 4: "Quarter", 8: "Eighth", 16: "16th", 32: "32nd", 64: "64th",
           128: "128th"}
_DYN = [(15, "PPP"), (31, "PP"), (47, "P"), (63, "MP"), (79, "MF"), (95, "F"), (111, "FF"),
        (127, "FFF")]
_SLIDE_BITS = {"shiftSlideTo": 1, "legatoSlideTo": 2, "outDownwards": 4, "outUpwards": 8,
               "intoFromBelow": 16, "intoFromAbove": 32}


def _prop(name: str, inner: str) -> str:
    return f'<Property name="{name}">{inner}</Property>'


def _camel(direction_name: str) -> str:
    return "".join(w[:1].upper() + w[1:] for w in direction_name.split())


class _Writer:
    def __init__(self, song):
        self.song = song
        self.rhythms: dict[tuple, int] = {}
        self.beats: list[str] = []
        self.notes: list[str] = []
        self.voices: list[str] = []
        self.bars: list[str] = []

    def rhythm(self, value: int, dotted: bool = False, enters: int = 1, times: int = 1) -> int:
        key = (value, dotted, enters, times)
        if key not in self.rhythms:
            self.rhythms[key] = len(self.rhythms)
        return self.rhythms[key]

    def note(self, note, track, extra_props: str = "", extra: str = "") -> int:
        n = len(track.strings)
        eff = note.effect
        props = [_prop("String", f"<String>{n - note.string}</String>"),
                 _prop("Fret", f"<Fret>{note.value}</Fret>")]
        if note.type.name == "dead":
            props.append(_prop("Muted", "<Enable/>"))
        if eff.palmMute:
            props.append(_prop("PalmMuted", "<Enable/>"))
        if eff.hammer:
            props.append(_prop("HopoOrigin", "<Enable/>"))
        bits = sum(_SLIDE_BITS.get(s.name, 0) for s in eff.slides)
        if bits:
            props.append(_prop("Slide", f"<Flags>{bits}</Flags>"))
        if eff.harmonic is not None:
            kind = type(eff.harmonic).__name__
            htype, hfret = {"NaturalHarmonic": ("Natural", note.value),
                            "ArtificialHarmonic": ("Artificial", 12),
                            "PinchHarmonic": ("Pinch", 12),
                            "SemiHarmonic": ("Semi", 12)}.get(kind, ("Tap", 12))
            if kind == "TappedHarmonic":
                hfret = int(eff.harmonic.fret) - note.value
            props.append(_prop("HarmonicType", f"<HType>{htype}</HType>"))
            props.append(_prop("HarmonicFret", f"<HFret>{hfret}</HFret>"))
        if eff.bend is not None and eff.bend.points:
            props.extend(self.bend(eff.bend.points))
        if note.beat.effect.slapEffect.name == "tapping":
            props.append(_prop("Tapped", "<Enable/>"))
        xml = [f'<Note id="{len(self.notes)}">']
        if note.type.name == "tie":
            xml.append('<Tie origin="false" destination="true"/>')
        if eff.letRing:
            xml.append("<LetRing/>")
        if eff.ghostNote:
            xml.append("<AntiAccent>Normal</AntiAccent>")
        acc = (1 if eff.staccato else 0) | (4 if eff.heavyAccentuatedNote else 0) | (
            8 if eff.accentuatedNote else 0)
        if acc:
            xml.append(f"<Accent>{acc}</Accent>")
        if eff.vibrato or note.beat.effect.vibrato:
            xml.append(f"<Vibrato>{'Wide' if note.beat.effect.vibrato else 'Slight'}</Vibrato>")
        if eff.trill is not None:
            open_pitch = next(s.value for s in track.strings if s.number == note.string)
            xml.append(f"<Trill>{open_pitch + eff.trill.fret}</Trill>")
        xml.append(extra)
        xml.append("<Properties>" + "".join(props) + extra_props + "</Properties></Note>")
        self.notes.append("".join(xml))
        return len(self.notes) - 1

    @staticmethod
    def bend(points) -> list[str]:
        """Origin, one middle value held between two offsets, destination (GPIF's shape)."""
        pts = sorted((p.position / 12.0 * 100.0, p.value * 25.0) for p in points)
        top = max(v for _, v in pts)

        def f(name, x):
            return _prop(name, f"<Float>{x:g}</Float>")

        out = [_prop("Bended", "<Enable/>"), f("BendOriginOffset", pts[0][0]),
               f("BendOriginValue", pts[0][1]), f("BendDestinationOffset", pts[-1][0]),
               f("BendDestinationValue", pts[-1][1])]
        if top > max(pts[0][1], pts[-1][1]):
            at = [o for o, v in pts if v == top]
            out += [f("BendMiddleValue", top), f("BendMiddleOffset1", at[0]),
                    f("BendMiddleOffset2", at[-1])]
        return out

    def beat(self, beat, track) -> list[int]:
        ids = []
        grace_notes = [n for n in beat.notes if n.effect.grace is not None]
        if grace_notes:
            g0 = grace_notes[0].effect.grace
            notes = []
            for n in grace_notes:
                g = n.effect.grace
                extra = ""
                if g.transition.name == "hammer":
                    extra = _prop("HopoOrigin", "<Enable/>")
                elif g.transition.name == "slide":
                    extra = _prop("Slide", "<Flags>2</Flags>")
                elif g.transition.name == "bend":
                    extra = _prop("Bended", "<Enable/>")
                if g.isDead:
                    extra += _prop("Muted", "<Enable/>")
                notes.append(self._raw_note(track, n.string, g.fret, extra))
            on = "OnBeat" if g0.isOnBeat else "BeforeBeat"
            ids.append(self._beat_xml(f"<GraceNotes>{on}</GraceNotes>"
                                      f'<Rhythm ref="{self.rhythm(g0.duration)}"/>'
                                      f"<Dynamic>{self.dyn(g0.velocity)}</Dynamic>", notes))
        d = beat.duration
        r = self.rhythm(d.value, d.isDotted, d.tuplet.enters, d.tuplet.times)
        body = [f'<Rhythm ref="{r}"/>']
        if beat.notes:
            body.append(f"<Dynamic>{self.dyn(beat.notes[0].velocity)}</Dynamic>")
            tp = beat.notes[0].effect.tremoloPicking
            if tp is not None:
                body.append(f"<Tremolo>{ {8: '1/2', 16: '1/4', 32: '1/8'}[tp.duration.value] }"
                            "</Tremolo>")
        be = beat.effect
        if be.fadeIn:
            body.append("<Fadding>FadeIn</Fadding>")
        props, xprops = [], []
        if be.stroke.direction.value:
            up = be.stroke.direction.name == "up"
            props.append(_prop("Brush", f"<Direction>{'Up' if up else 'Down'}</Direction>"))
            if be.stroke.value:
                xprops.append(f'<XProperty id="687935489"><Int>{1920 // be.stroke.value}</Int>'
                              "</XProperty>")
        if be.slapEffect.name in ("slapping", "popping"):
            props.append(_prop("Slapped" if be.slapEffect.name == "slapping" else "Popped",
                               "<Enable/>"))
        if be.hasRasgueado:
            props.append(_prop("Rasgueado", "<Rasgueado>ii_1</Rasgueado>"))
        if be.tremoloBar is not None:
            props.append(_prop("WhammyBar", "<Enable/>"))
        if props:
            body.append("<Properties>" + "".join(props) + "</Properties>")
        if xprops:
            body.append("<XProperties>" + "".join(xprops) + "</XProperties>")
        notes = [self.note(n, track) for n in beat.notes if n.type.name != "rest"]
        ids.append(self._beat_xml("".join(body), notes))
        return ids

    def _raw_note(self, track, string: int, fret: int, extra_props: str) -> int:
        n = len(track.strings)
        self.notes.append(f'<Note id="{len(self.notes)}"><Properties>'
                          + _prop("String", f"<String>{n - string}</String>")
                          + _prop("Fret", f"<Fret>{fret}</Fret>") + extra_props
                          + "</Properties></Note>")
        return len(self.notes) - 1

    def _beat_xml(self, body: str, notes: list[int]) -> int:
        n = f"<Notes>{' '.join(map(str, notes))}</Notes>" if notes else ""
        self.beats.append(f'<Beat id="{len(self.beats)}">{body}{n}</Beat>')
        return len(self.beats) - 1

    @staticmethod
    def dyn(velocity: int) -> str:
        return next((name for v, name in _DYN if velocity <= v), "FFF")

    def document(self) -> bytes:
        song = self.song
        tracks, master_bars, autos = [], [], []
        autos.append(f"<Automation><Type>Tempo</Type><Linear>false</Linear><Bar>0</Bar>"
                     f"<Position>0</Position><Value>{song.tempo} 2</Value></Automation>")
        for t in song.tracks:
            tuning = " ".join(str(s.value) for s in sorted(t.strings, key=lambda s: -s.number))
            tracks.append(
                f'<Track id="{t.number - 1}"><Name><![CDATA[{t.name}]]></Name>'
                f"<Properties>{_prop('Tuning', f'<Pitches>{tuning}</Pitches>')}"
                f"{_prop('CapoFret', f'<Fret>{t.offset}</Fret>')}</Properties>"
                f"<GeneralMidi><Program>{t.channel.instrument}</Program>"
                f"<PrimaryChannel>{9 if t.isPercussionTrack else t.channel.channel}"
                "</PrimaryChannel></GeneralMidi></Track>")
        for k, h in enumerate(song.measureHeaders):
            bar_ids = []
            for t in song.tracks:
                m = t.measures[k]
                vids = []
                for voice in m.voices[:4]:
                    beat_ids = []
                    for b in voice.beats:
                        mix = b.effect.mixTableChange
                        if mix is not None and mix.tempo is not None and mix.tempo.value > 0:
                            pos = (b.start - h.start) / h.length
                            autos.append(f"<Automation><Type>Tempo</Type><Linear>false</Linear>"
                                         f"<Bar>{k}</Bar><Position>{pos:g}</Position>"
                                         f"<Value>{mix.tempo.value} 2</Value></Automation>")
                        beat_ids += self.beat(b, t)
                    self.voices.append(f'<Voice id="{len(self.voices)}"><Beats>'
                                       f"{' '.join(map(str, beat_ids))}</Beats></Voice>")
                    vids.append(len(self.voices) - 1)
                vids += [-1] * (4 - len(vids))
                self.bars.append(f'<Bar id="{len(self.bars)}"><Voices>{" ".join(map(str, vids))}'
                                 "</Voices></Bar>")
                bar_ids.append(len(self.bars) - 1)
            ts = h.timeSignature
            x = [f"<Time>{ts.numerator}/{ts.denominator.value}</Time>"]
            if h.isRepeatOpen or h.repeatClose > 0:
                end = "true" if h.repeatClose > 0 else "false"
                x.append(f'<Repeat start="{str(h.isRepeatOpen).lower()}" end="{end}" '
                         f'count="{max(h.repeatClose + 1, 0)}"/>')
            if h.repeatAlternative:
                x.append("<AlternateEndings>" + " ".join(
                    str(i + 1) for i in range(8) if h.repeatAlternative >> i & 1)
                    + "</AlternateEndings>")
            if h.tripletFeel.name != "none":
                feel = "Triplet8th" if h.tripletFeel.name == "eighth" else "Triplet16th"
                x.append(f"<TripletFeel>{feel}</TripletFeel>")
            d = []
            if h.direction is not None and h.direction.name:
                d.append(f"<Target>{_camel(h.direction.name)}</Target>")
            if h.fromDirection is not None and h.fromDirection.name:
                d.append(f"<Jump>{_camel(h.fromDirection.name)}</Jump>")
            if d:
                x.append("<Directions>" + "".join(d) + "</Directions>")
            x.append(f"<Bars>{' '.join(map(str, bar_ids))}</Bars>")
            master_bars.append("<MasterBar>" + "".join(x) + "</MasterBar>")
        rhythms = []
        for (value, dotted, enters, times), i in self.rhythms.items():
            r = f'<Rhythm id="{i}"><NoteValue>{_VALUES[value]}</NoteValue>'
            if dotted:
                r += '<AugmentationDot count="1"/>'
            if (enters, times) != (1, 1):
                r += f'<PrimaryTuplet num="{enters}" den="{times}"/>'
            rhythms.append(r + "</Rhythm>")
        track_ids = " ".join(str(t.number - 1) for t in song.tracks)
        doc = (
            '<?xml version="1.0" encoding="utf-8"?>\n<GPIF><GPVersion>7</GPVersion>'
            f"<Score><Title><![CDATA[{song.title}]]></Title>"
            f"<Artist><![CDATA[{song.artist}]]></Artist></Score>"
            f"<MasterTrack><Tracks>{track_ids}</Tracks><Automations>{''.join(autos)}"
            "</Automations></MasterTrack>"
            f"<Tracks>{''.join(tracks)}</Tracks><MasterBars>{''.join(master_bars)}</MasterBars>"
            f"<Bars>{''.join(self.bars)}</Bars><Voices>{''.join(self.voices)}</Voices>"
            f"<Beats>{''.join(self.beats)}</Beats><Notes>{''.join(self.notes)}</Notes>"
            f"<Rhythms>{''.join(rhythms)}</Rhythms></GPIF>")
        return doc.encode("utf-8")


def gpif(song) -> bytes:
    """The GPIF document (score.gpif) of a PyGuitarPro song."""
    return _Writer(song).document()


def gp7(xml: bytes) -> bytes:
    """A Guitar Pro 7 file (zip) holding ``xml`` as Content/score.gpif."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("VERSION", "7.0")
        z.writestr("Content/score.gpif", xml)
    return buf.getvalue()


def bcfs(files: dict[str, bytes]) -> bytes:
    """A BCFS container ('BCFS' + 4096-byte sectors: sector 0 unused, then per file an entry
    sector (type 2, name, size, sector numbers) and its data sectors)."""
    sec = 0x1000
    out = bytearray(sec)
    for name, data in files.items():
        entry_at = len(out)
        n_data = (len(data) + sec - 1) // sec
        first = entry_at // sec + 1
        entry = bytearray(sec)
        entry[0:4] = (2).to_bytes(4, "little")
        entry[4:4 + len(name)] = name.encode("latin-1")
        entry[0x8C:0x90] = len(data).to_bytes(4, "little")
        for k in range(n_data):
            entry[0x94 + 4 * k:0x98 + 4 * k] = (first + k).to_bytes(4, "little")
        out += entry
        out += data + bytes(n_data * sec - len(data))
    return b"BCFS" + bytes(out)


def bcfz(raw: bytes) -> bytes:
    """BCFZ compression of ``raw``: greedy LZ77 copies (a 4-byte match found through a table of
    earlier positions) and literal runs of up to 3 bytes, in GP6's bit layout."""
    bits: list[int] = []

    def put(value: int, n: int, reverse: bool = False) -> None:
        rng = range(n) if reverse else range(n - 1, -1, -1)
        bits.extend((value >> i) & 1 for i in rng)

    seen: dict[bytes, int] = {}
    i, lit = 0, bytearray()

    def flush() -> None:
        while lit:
            chunk = lit[:3]
            del lit[:3]
            put(0, 1)
            put(len(chunk), 2, reverse=True)
            for b in chunk:
                put(b, 8)

    while i < len(raw):
        key = raw[i:i + 4]
        j = seen.get(key) if len(key) == 4 else None
        seen[key] = i
        if j is not None and 4 <= i - j < 32768:  # a copy never overlaps its source
            offset = i - j
            size = 4
            while i + size < len(raw) and size < offset and size < 32767 \
                    and raw[j + size] == raw[i + size]:
                size += 1
            flush()
            w = max(offset.bit_length(), size.bit_length())
            put(1, 1)
            put(w, 4)
            put(offset, w, reverse=True)
            put(size, w, reverse=True)
            i += size
            continue
        lit.append(raw[i])
        i += 1
    flush()
    bits.extend([0] * (-len(bits) % 8))
    packed = bytes(int("".join(map(str, bits[k:k + 8])), 2) for k in range(0, len(bits), 8))
    return b"BCFZ" + len(raw).to_bytes(4, "little") + packed


def gpx(xml: bytes, compressed: bool = True) -> bytes:
    """A Guitar Pro 6 file holding ``xml`` as score.gpif (BCFZ-compressed unless told not)."""
    container = bcfs({"score.gpif": xml, "misc.xml": b"<misc/>"})
    return bcfz(container) if compressed else container

