"""Small score files that the tests write themselves (PyGuitarPro for Guitar Pro 5, mido for MIDI),
and hostile ones: the first bytes of a file and nothing after, a zip renamed .gp5."""

from __future__ import annotations

import io
import zipfile

STANDARD_TUNING = [64, 59, 55, 50, 45, 40]  # MIDI pitches of strings 1..6
NOTES = ((2, 3), (3, 2), (1, 0), (2, 1))  # (string, fret) quarter notes: D4 A3 E4 C4


def small_gp5(notes: tuple[tuple[int, int], ...] = NOTES, tracks: int = 2, tempo: int = 120,
              duration: int = 4) -> bytes:
    """A Guitar Pro 5 file of ``tracks`` guitar tracks, each playing ``notes`` (string, fret) in
    one measure, each note 1/``duration`` of a whole note long."""
    import guitarpro as gp

    song = gp.Song()
    song.tempo = tempo
    for t in range(1, tracks):
        tr = gp.Track(song, number=t + 1, name=f"Track {t + 1}")
        tr.strings = [gp.GuitarString(n, v) for n, v in enumerate(STANDARD_TUNING, 1)]
        tr.measures = [gp.Measure(tr, h) for h in song.measureHeaders]
        song.tracks.append(tr)
    for tr in song.tracks:
        voice = tr.measures[0].voices[0]
        for string, fret in notes:
            beat = gp.Beat(voice, duration=gp.Duration(value=duration))
            beat.notes.append(gp.Note(beat, value=fret, string=string, type=gp.NoteType.normal))
            beat.status = gp.BeatStatus.normal
            voice.beats.append(beat)
    buf = io.BytesIO()
    gp.write(song, buf, version=(5, 1, 0))
    return buf.getvalue()


def truncated_gp5() -> bytes:
    """The first bytes of a Guitar Pro 5 file (its version string) and nothing after."""
    version = b"FICHIER GUITAR PRO v5.00"
    return bytes([len(version)]) + version.ljust(30, b"\0") + b"\x05\x00\x00"


def zip_as_gp5() -> bytes:
    """A zip archive that holds no Guitar Pro score (a Guitar Pro 7 file, a zip holding
    Content/score.gpif, is read whatever its name), renamed .gp5."""
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("word/document.xml", "<w/>")
    return buf.getvalue()


def truncated_midi() -> bytes:
    """A MIDI header announcing two tracks, and a first track cut short."""
    return b"MThd\x00\x00\x00\x06\x00\x01\x00\x02\x01\xe0MTrk\x00\x00"


def small_midi(pitches: tuple[int, ...] = (52, 55, 59, 64), beat_s: float = 0.5,
               program: int = 25) -> bytes:
    """A Standard MIDI File of one part on ``program`` (General MIDI, 0-based: 25 is the steel
    guitar) playing ``pitches`` one after another, ``beat_s`` apart, at 120 bpm."""
    import mido

    mid = mido.MidiFile(type=1, ticks_per_beat=480)
    track = mido.MidiTrack([mido.MetaMessage("set_tempo", tempo=500_000, time=0),
                            mido.Message("program_change", program=program, time=0)])
    ticks = round(beat_s * 960)
    for p in pitches:
        track.append(mido.Message("note_on", note=p, velocity=90, time=0))
        track.append(mido.Message("note_off", note=p, velocity=0, time=ticks))
    mid.tracks.append(track)
    buf = io.BytesIO()
    mid.save(file=buf)
    return buf.getvalue()


def midi_with_notes(n: int) -> bytes:
    """A one-track MIDI file of ``n`` notes, 6 bytes each (running status): 10**6 notes in 6 MB."""
    body = b"\x00\x90\x3c\x40" + b"\x60\x3c\x00\x00\x3c\x40" * (n - 1) + b"\x60\x3c\x00"
    body += b"\x00\xff\x2f\x00"
    return (b"MThd" + (6).to_bytes(4, "big") + b"\x00\x00\x00\x01\x01\xe0"
            + b"MTrk" + len(body).to_bytes(4, "big") + body)


def dense_midi(n: int) -> bytes:
    """A one-track MIDI file of ``n`` short notes one tick apart (480 ticks a beat, 120 bpm: about
    a millisecond each) climbing through the guitar's range: 30,000 notes in 240 KB and 31 s."""
    body = bytearray((0, 0xC0, 25))  # a steel-string guitar (GM program 26), as the importer plays
    for i in range(n):
        pitch = 40 + (i * 7) % 36
        body += bytes((0, 0x90, pitch, 0x40, 1, 0x80, pitch, 0))
    body += b"\x00\xff\x2f\x00"
    return (b"MThd" + (6).to_bytes(4, "big") + b"\x00\x00\x00\x01\x01\xe0"
            + b"MTrk" + len(body).to_bytes(4, "big") + bytes(body))


def gp5_claiming_measures(count: int) -> bytes:
    """A valid small Guitar Pro 5 file whose header then claims ``count`` measures (the engine's
    score tests find where the count is stored)."""
    from tests.engine.score.test_bad_input import _measure_count_offset

    data = bytearray(small_gp5(tracks=1))
    at = _measure_count_offset(bytes(data))
    assert int.from_bytes(data[at:at + 4], "little") == 1
    data[at:at + 4] = count.to_bytes(4, "little")
    return bytes(data)
