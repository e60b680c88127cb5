"""Small Guitar Pro files written with PyGuitarPro, for the tests."""

from __future__ import annotations

import io

import guitarpro as gp


def song(measures: list[list[list[tuple]]], tempo: int = 120, strings=None, instrument=25,
         capo: int = 0, version=(5, 1, 0), beat_effects=None) -> bytes:
    """A one-track song: ``measures`` is a list of measures, each a list of beats, each a list of
    notes ``(string, fret, effects dict)``, every beat a quarter note (an empty beat is a rest).
    ``beat_effects``: {(measure, beat): callable(beat)}."""
    s = gp.Song()
    s.tempo = tempo
    track = s.tracks[0]
    track.channel.instrument = instrument
    track.offset = capo
    if strings is not None:
        track.strings = [gp.GuitarString(i + 1, v) for i, v in enumerate(strings)]
    header0 = s.measureHeaders[0]
    for k in range(1, len(measures)):
        h = gp.MeasureHeader(number=k + 1, start=header0.start + k * header0.length,
                             timeSignature=header0.timeSignature)
        s.measureHeaders.append(h)
        track.measures.append(gp.Measure(track, h))
    for mi, beats in enumerate(measures):
        measure = track.measures[mi]
        voice = measure.voices[0]
        start = measure.header.start
        for bi, notes in enumerate(beats):
            beat = gp.Beat(voice, start=start + bi * 960)
            beat.duration = gp.Duration(4)
            beat.status = gp.BeatStatus.normal if notes else gp.BeatStatus.rest
            for string, fret, eff in notes:
                note = gp.Note(beat, value=fret, string=string, type=gp.NoteType.normal)
                for k, v in (eff or {}).items():
                    if k == "type":
                        note.type = v
                    elif k == "velocity":
                        note.velocity = v
                    else:
                        setattr(note.effect, k, v)
                beat.notes.append(note)
            if beat_effects and (mi, bi) in beat_effects:
                beat_effects[(mi, bi)](beat)
            voice.beats.append(beat)
    buf = io.BytesIO()
    gp.write(s, buf, version=version)
    return buf.getvalue()
