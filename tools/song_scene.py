"""The scene a song's command-line render renders, for the tools that measure songs.

``song_scene(FILE, S, MODEL)`` is what ``guitar-synth render FILE --model MODEL --all-instruments
[--max-seconds S]`` renders: ``benchmarks.songs``' command, so that the tools' figures are of the
same notes as the song benchmark's (a MIDI file with no guitar part has none without
``--all-instruments``).
"""

from __future__ import annotations

from pathlib import Path


def song_scene(path: str | Path, seconds: float | None = None, model: str = "waveguide"):
    """The validated scene (``engine.scene.Scene``) of ``path`` as the CLI renders it."""
    from cli.main import build_parser, load_input, validate

    argv = ["render", str(path), "-o", "/dev/null", "--model", model, "--all-instruments"]
    if seconds is not None:
        argv += ["--max-seconds", str(seconds)]
    scene, _ = load_input(build_parser().parse_args(argv))
    return validate(scene, str(path))
