"""Scores in, labels out: Guitar Pro 3-8 and Standard MIDI Files become scenes (the JSON form of
``../shared/API.md``, with ``tracks``), and any scene's notes become a JAMS file.

    >>> import engine.score as score
    >>> scene = score.score_to_scene("song.gp5", tracks=[1], max_seconds=30)
    >>> scene.warnings          # what could not be played, each naming bar, beat, track, effect
    >>> jam = score.scene_labels(scene)   # jams.JAMS, GuitarSet's layout

Modules: ``gp`` (Guitar Pro 3-5, via PyGuitarPro, and the song -> scene mapping every Guitar Pro
version shares), ``gpif`` (Guitar Pro 6 .gpx and 7/8 .gp -> PyGuitarPro's song model), ``midi``
(Standard MIDI Files, via pretty_midi and mido), ``fingering`` (strings and frets for MIDI notes),
``labels`` (scene -> JAMS), ``common`` (limits, the event builder).  This package knows only the
scene's JSON form and ``engine.presets``; it renders nothing.
"""

from __future__ import annotations

import os

from ..performance import truncate
from ..scene import MAX_DURATION_S, MAX_TRACKS
from .common import MAX_SCORE_BYTES, ScoreError
from .labels import save_labels, scene_labels, scene_notes

__all__ = ["FORMATS", "SCORE_SUFFIXES", "SUFFIXES", "WARNING_MODES", "ScoreError", "ScoreScene",
           "group_warnings", "save_labels", "scene_labels", "scene_notes", "score_to_scene",
           "select_warnings"]

_OPTIONS = {"tracks", "presets", "tempo_scale", "max_seconds", "format", "sample_rate",
            "all_instruments"}
FORMATS = ("gp", "gpx", "gp7", "musicxml", "midi")
# the file names a score may have (the CLI, batches and the upload endpoints accept these)
SUFFIXES = (".gp3", ".gp4", ".gp5", ".gpx", ".gp", ".musicxml", ".xml", ".mxl", ".mid", ".midi")
SCORE_SUFFIXES = SUFFIXES  # as ``engine.SCORE_SUFFIXES``
from .warnings import MODES as WARNING_MODES  # noqa: E402
from .warnings import group as group_warnings  # noqa: E402
from .warnings import select as select_warnings  # noqa: E402


class ScoreScene(dict):
    """The scene (a plain ``dict`` in the JSON form, ready for ``engine.render``), with the
    conversion's report as attributes: ``warnings`` (list of one-line strings), ``notes`` (the
    score's notes as played: track, string, fret, time, end, pitch, articulations, bar and beat)
    and ``format`` ("gp", "gpx", "gp7" or "midi")."""

    warnings: list[str]
    notes: list[dict]
    format: str


def _read(source) -> tuple[bytes, str]:
    """(bytes, name) of a path, bytes or binary file object, at most ``MAX_SCORE_BYTES``."""
    if isinstance(source, bytes | bytearray | memoryview):
        data = bytes(source)
        name = ""
    elif isinstance(source, str | os.PathLike):
        name = os.fspath(source)
        try:
            size = os.path.getsize(name)
            if size > MAX_SCORE_BYTES:
                raise ScoreError(f"score file is {size} bytes; the limit is {MAX_SCORE_BYTES}")
            with open(name, "rb") as f:
                data = f.read(MAX_SCORE_BYTES + 1)
        except OSError as exc:
            raise ScoreError(f"cannot read {name!r}: {exc.strerror or exc}") from None
    elif hasattr(source, "read"):
        name = str(getattr(source, "name", "") or "")
        data = source.read(MAX_SCORE_BYTES + 1)
        if isinstance(data, str):
            raise ScoreError("score file opened in text mode; open it in binary mode ('rb')")
        data = bytes(data)
    else:
        raise ScoreError(f"score source must be a path, bytes or a binary file, not "
                         f"{type(source).__name__}")
    if len(data) > MAX_SCORE_BYTES:
        raise ScoreError(f"score file is larger than the limit of {MAX_SCORE_BYTES} bytes")
    if not data:
        raise ScoreError("score file is empty (0 bytes)")
    return data, name


def sniff(data: bytes, name: str = "") -> str:
    """'gp' (Guitar Pro 3/4/5), 'gpx' (Guitar Pro 6), 'gp7' (Guitar Pro 7/8) or 'midi' from the
    file's first bytes (its name's suffix only breaks no tie)."""
    from .gpif import sniff as gpif_sniff

    if data[:4] == b"MThd" or data[:4] == b"RIFF" and data[8:12] == b"RMID":
        return "midi"
    if data[1:19] in (b"FICHIER GUITAR PRO", b"CLIPBOARD GUITAR P") or data[1:13] == b"CLIPBOARD GP":
        return "gp"
    kind = gpif_sniff(data)
    if kind is not None:
        return kind
    from .musicxml import sniff as musicxml_sniff

    if musicxml_sniff(data):
        return "musicxml"
    suffix = os.path.splitext(name)[1].lower()
    base = os.path.basename(name)
    if data[:4] == b"PK\x03\x04":
        if suffix == ".gp":
            return "gp7"  # the reader names what is missing (Content/score.gpif)
        if suffix == ".mxl":
            return "musicxml"
        raise ScoreError("a zip archive without Content/score.gpif: not a Guitar Pro 7/8 file")
    if suffix in (".gp3", ".gp4", ".gp5"):
        raise ScoreError(f"not a Guitar Pro 3/4/5 file despite its name {base!r} "
                         "(no Guitar Pro header)")
    if suffix == ".gpx":
        raise ScoreError(f"not a Guitar Pro 6 file despite its name {base!r} (no BCFZ/BCFS "
                         "header)")
    if suffix == ".gp":
        raise ScoreError(f"not a Guitar Pro 7/8 file despite its name {base!r} (not a zip "
                         "archive)")
    if suffix in (".mid", ".midi"):
        raise ScoreError(f"not a MIDI file despite its name {base!r} (no 'MThd' header)")
    if suffix in (".musicxml", ".xml", ".mxl"):
        raise ScoreError(f"not a MusicXML score despite its name {base!r} (no <score-partwise> "
                         "or <score-timewise>)")
    raise ScoreError("not a Guitar Pro (3-8) or Standard MIDI file (unknown header "
                     f"{data[:8]!r})")


def score_to_scene(source, **options) -> ScoreScene:
    """A Guitar Pro (3/4/5 .gp3-.gp5, 6 .gpx, 7/8 .gp) or Standard MIDI file as a scene
    (``../shared/API.md``, "Scores in").

    ``source``: a path, the file's bytes, or a binary file object.  Options:

    * ``tracks``: the tracks to keep, by number as the score numbers them (Guitar Pro's track
      number, 1-based; for MIDI, the 1-based index of the score's parts, one part per channel and
      program, in the order ``ScoreScene.notes``/warnings name them) or by name; default all
      guitar and bass tracks (General MIDI programs 24-39); a track asked for by number or name
      is played whatever its instrument.
    * ``all_instruments``: true plays every pitched track (piano, voice, strings ...) on a guitar
      too; by default each other instrument is skipped and named in the warnings.
    * ``presets``: one preset name for every track, or ``{track number or name: preset}``; default
      from the instrument (General MIDI program; string count).
    * ``tempo_scale``: > 0, multiplies the tempo (2.0 plays twice as fast); default 1.
    * ``max_seconds``: cut the scene there (events after it dropped, duration clamped).
    * ``format``: "gp", "gpx", "gp7" or "midi" to skip detection from the file's header.
    * ``sample_rate``: the scene's sample rate (default 44100).

    Returns a ``ScoreScene`` (a dict) with ``.warnings`` and ``.notes``.  Raises ``ScoreError``
    (a ``ValueError``) with one line naming the problem for anything that is not a readable score.
    """
    unknown = set(options) - _OPTIONS
    if unknown:
        raise ScoreError(f"unknown option(s) {sorted(unknown)}; allowed: {sorted(_OPTIONS)}")
    scale = options.get("tempo_scale", 1.0)
    try:
        scale = float(scale)
    except (TypeError, ValueError):
        raise ScoreError(f"options.tempo_scale: {scale!r} is not a number") from None
    if not 0.05 <= scale <= 20.0:
        raise ScoreError(f"options.tempo_scale: {scale} outside 0.05..20")
    options["tempo_scale"] = scale
    tracks = options.get("tracks")
    if tracks is not None:
        if isinstance(tracks, int | str):
            tracks = [tracks]
        options["tracks"] = set(tracks)
    max_s = options.get("max_seconds")
    if max_s is not None and not (isinstance(max_s, int | float) and max_s > 0):
        raise ScoreError(f"options.max_seconds: {max_s!r} must be a number > 0")
    data, name = _read(source)
    fmt = options.get("format") or sniff(data, name)
    warnings: list[str] = []
    if not isinstance(options.get("all_instruments", False), bool):
        raise ScoreError(f"options.all_instruments: {options['all_instruments']!r} is not true "
                         "or false")
    if fmt in ("gp", "gpx", "gp7", "musicxml"):
        from . import gp

        if fmt == "gp":
            song = gp.parse_song(data)
        elif fmt == "musicxml":
            from . import musicxml

            song = musicxml.parse_song(data, warnings)
        else:
            from . import gpif

            song = gpif.parse_song(data, warnings)
        scene, planned = gp.convert(song, options, warnings)
    elif fmt == "midi":
        from . import midi

        scene, planned = midi.convert(data, options, warnings)
    else:
        raise ScoreError(f"options.format: {fmt!r} is not one of {list(FORMATS)}")
    if not planned:
        raise ScoreError("the score has no notes to play" + (" in the chosen tracks"
                                                              if options.get("tracks") else ""))
    if options.get("sample_rate"):
        scene["sample_rate"] = int(options["sample_rate"])
    if scene["duration"] > MAX_DURATION_S and max_s is None:
        raise ScoreError(f"score plays for {scene['duration']:.0f} s; a scene plays at most "
                         f"{MAX_DURATION_S:.0f} s (options.max_seconds renders the start)")
    if len(scene["tracks"]) > MAX_TRACKS:
        scene, planned = _keep_busiest_tracks(scene, planned, warnings)
    names = [t["name"] for t in scene["tracks"]]
    notes = [p.report(names) for p in planned]
    if max_s is not None:
        scene = truncate(scene, float(max_s))
        notes = [n for n in notes if n["time"] < max_s]
    info = scene.get("score")
    if info is not None:
        info["title"] = (info.get("title") or "")[:300]
        info["artist"] = (info.get("artist") or "")[:300]
        info["source"] = os.path.basename(name)[:300]
        info["format"] = fmt
        cut_score_info(info, float(scene["duration"]))
    out = ScoreScene(scene)
    out.warnings = warnings
    out.notes = sorted(notes, key=lambda n: (n["time"], n["track"], n["string"]))
    out.format = fmt
    return out


def cut_score_info(info: dict, seconds: float) -> dict:
    """The score info of a scene cut at ``seconds`` (in place): its bars, beats, tempo changes,
    keys and chords from then on dropped."""
    for times, values in (("bars", "bar_numbers"), ("beats", "beat_positions")):
        keep = [i for i, t in enumerate(info.get(times) or []) if t < seconds]
        info[times] = [info[times][i] for i in keep]
        info[values] = [info[values][i] for i in keep]
    for key in ("tempo", "keys", "chords"):
        if key in info:
            info[key] = [m for m in info[key] if m["time"] < seconds]
    return info


def _keep_busiest_tracks(scene: dict, planned: list, warnings: list[str]) -> tuple[dict, list]:
    """A scene holds at most ``MAX_TRACKS`` instruments: keep the tracks with the most notes (in
    the score's order) and name each one left out in the warnings."""
    counts = [0] * len(scene["tracks"])
    for p in planned:
        counts[p.track] += 1
    ranked = sorted(range(len(counts)), key=lambda i: (-counts[i], i))
    keep = sorted(ranked[:MAX_TRACKS])
    for i in sorted(ranked[MAX_TRACKS:]):
        warnings.append(f"track '{scene['tracks'][i]['name']}' ({i + 1}) left out: a scene holds "
                        f"at most {MAX_TRACKS} tracks, and it has fewer notes ({counts[i]}) than "
                        "the tracks kept")
    index = {old: new for new, old in enumerate(keep)}
    kept = [p for p in planned if p.track in index]
    for p in kept:
        p.track = index[p.track]
    return {**scene, "tracks": [scene["tracks"][i] for i in keep]}, kept
