"""Small scores for the tests of the code that takes scores (the service's jobs, the batch)."""

from __future__ import annotations

import io


def gp5_song(notes: list[tuple[int, int]], tempo: int = 120) -> bytes:
    """A one-track Guitar Pro 5 file (PyGuitarPro): one quarter-note beat per (string, fret)."""
    import guitarpro as gp

    song = gp.Song()
    song.tempo = tempo
    track = song.tracks[0]
    header = song.measureHeaders[0]
    for k in range(1, (len(notes) + 3) // 4):
        h = gp.MeasureHeader(number=k + 1, start=header.start + k * header.length,
                             timeSignature=header.timeSignature)
        song.measureHeaders.append(h)
        track.measures.append(gp.Measure(track, h))
    for i, (string, fret) in enumerate(notes):
        measure = track.measures[i // 4]
        voice = measure.voices[0]
        beat = gp.Beat(voice, start=measure.header.start + (i % 4) * 960)
        beat.duration = gp.Duration(4)
        beat.status = gp.BeatStatus.normal
        beat.notes.append(gp.Note(beat, value=fret, string=string, type=gp.NoteType.normal))
        voice.beats.append(beat)
    buf = io.BytesIO()
    gp.write(song, buf, version=(5, 1, 0))
    return buf.getvalue()
