"""guitar-synth: render scenes and scores to audio, turn scores into scenes, serve HTTP.

    guitar-synth render song.gp5 -o song.flac --labels song.jams --tracks 1,3
    guitar-synth render song.gp5 -o song.wav --stems      (each string in song.stems/)
    guitar-synth scene tune.mid -o tune.json
    guitar-synth serve --port 8000
    guitar-synth batch songs/ dataset.yaml -o out/ [--scheduler tcp://host:8786]

Bad input (a missing, truncated or wrong-type file, an invalid scene, an unknown output suffix)
ends with one line on stderr naming the problem and exit status 2; an unexpected failure with one
line and status 1 (``--debug`` shows the traceback).  The command knows the engine only by its
public API (``engine.parse_scene``, ``engine.blocks``, ``engine.frame_count``,
``engine.score_to_scene``, ``engine.scene_labels``) and the service only as
``service.app:app``.
"""

from __future__ import annotations

import argparse
import gc
import json
import math
import os
import sys
import time
from pathlib import Path
from typing import Any, NoReturn

from cli.common import (
    EXIT_BAD_INPUT,
    SCENE_SUFFIXES,
    SCORE_SUFFIXES,
    BadInput,
    OneLineParser,
    set_model,
)

AUDIO_FORMATS = {".wav": "wav", ".flac": "flac", ".ogg": "ogg"}
MAX_WARNINGS_SHOWN = 10
INPUT_HELP = f"scene .json or a score ({', '.join(SCORE_SUFFIXES)})"
WARNING_MODES = ("summary", "all", "none")  # engine.score.warnings.MODES (imported when needed)
EXIT_INTERNAL = 1


# ---- argument parsing ----------------------------------------------------------------------


def _positive_float(text: str) -> float:
    try:
        x = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not (math.isfinite(x) and x > 0):
        raise argparse.ArgumentTypeError(f"must be a positive number, not {text!r}")
    return x


def _cores() -> int:
    """The cores this process may run on (a container's cpuset, ``taskset``), not the host's."""
    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1


def _jobs(text: str) -> int:
    try:
        n = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a whole number: {text!r}") from None
    if n < 1:
        raise argparse.ArgumentTypeError(f"at least 1 thread, not {n}")
    return n


def _track_list(text: str) -> list[int | str]:
    """``1,3`` or ``Lead,Bass``: score track numbers (from 1) or names."""
    items = [t.strip() for t in text.split(",") if t.strip()]
    if not items:
        raise argparse.ArgumentTypeError("give track indices or names separated by commas")
    return [int(t) if t.isdigit() else t for t in items]


def _add_score_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("scores (Guitar Pro, MusicXML and MIDI input)")
    g.add_argument("--tracks", type=_track_list, metavar="LIST",
                   help="the score's tracks to play, by number as the score numbers them (from "
                        "1) or by name, comma-separated (default: every pitched track)")
    g.add_argument("--preset", metavar="NAME",
                   help="the preset of every track (default: from the score: General MIDI "
                        "program or Guitar Pro instrument); for a scene, its guitar's preset")
    g.add_argument("--tempo-scale", type=_positive_float, metavar="X",
                   help="play X times as fast (default 1)")
    g.add_argument("--max-seconds", type=_positive_float, metavar="S",
                   help="keep only the first S seconds (a score or a scene)")
    g.add_argument("--all-instruments", action="store_true",
                   help="play every pitched track of a score (piano, voice, strings ...) on a "
                        "guitar; by default only guitar and bass tracks are played and the others "
                        "are named in the warnings")
    g.add_argument("--warnings", choices=WARNING_MODES, default="summary",
                   help="what cannot be played: summary (the default: one line per kind and "
                        "track, with its bars), all (one line per beat) or none")


def _add_render_options(p: argparse.ArgumentParser) -> None:
    g = p.add_argument_group("rendering (override the scene's own fields)")
    g.add_argument("--quality", choices=("draft", "standard", "high"))
    g.add_argument("--sample-rate", type=int, metavar="HZ")
    g.add_argument("--channels", type=int, choices=(1, 2), help="1 mono, 2 stereo")
    g.add_argument("--model", choices=("fdtd", "waveguide"),
                   help="the string model of every track: fdtd, the finite-difference string "
                        "(the default), or waveguide, the digital waveguide (many times cheaper)")


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(prog="guitar-synth", description=__doc__.split("\n\n")[0],
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--debug", action="store_true",
                        help="show the traceback of an unexpected failure")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    sub.required = True

    r = sub.add_parser("render", help="render a scene or a score to an audio file",
                       description="Render a scene (.json) or a score (Guitar Pro, MusicXML or "
                                   "MIDI) to WAV, FLAC or Ogg Vorbis, with a progress bar on "
                                   "stderr.")
    r.add_argument("input", metavar="INPUT", help=INPUT_HELP)
    r.add_argument("-o", "--output", required=True, metavar="OUTPUT",
                   help="audio file; its suffix picks the format: .wav, .flac or .ogg")
    r.add_argument("--labels", metavar="LABELS.jams",
                   help="also write the note labels as JAMS (GuitarSet layout)")
    r.add_argument("--subtype", choices=("PCM_16", "PCM_24", "FLOAT"),
                   help="WAV sample format (default PCM_16; FLAC keeps 24 bits for PCM_24/FLOAT)")
    norm = r.add_mutually_exclusive_group()
    norm.add_argument("--normalize", dest="normalize", action="store_true", default=None,
                      help="scale the peak to -1 dBFS (the default)")
    norm.add_argument("--no-normalize", dest="normalize", action="store_false",
                      help="the fixed gain: loudness follows force")
    r.add_argument("--stems", action="store_true",
                   help="also each string's signal before body, pan, effects and mix, one file "
                        "per string in OUTPUT's name with .stems (song.stems/t1-s6.wav ...; "
                        "stems.json lists them), at the mix's format and gain: they sum to the "
                        "dry mix")
    r.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")
    r.add_argument("-j", "--jobs", type=_jobs, metavar="N",
                   help="threads to compute the strings on (default: the cores this process may "
                        "use); the samples are the same for any number")
    _add_score_options(r)
    _add_render_options(r)
    r.set_defaults(func=cmd_render)

    sub.add_parser("batch", help="render many scenes, scores or a dataset spec on Dask, with "
                                 "a manifest (guitar-synth batch --help)", add_help=False)

    s = sub.add_parser("scene", help="write the scene a score becomes, as JSON",
                       description="Turn a Guitar Pro, MusicXML or MIDI file into a scene (JSON): "
                                   "to read, edit, render or send to POST /render. A scene .json is "
                                   "checked and written back with its overrides applied.")
    s.add_argument("input", metavar="INPUT", help=INPUT_HELP)
    s.add_argument("-o", "--output", required=True, metavar="SCENE.json",
                   help="where to write the scene ('-' for standard output)")
    _add_score_options(s)
    _add_render_options(s)
    s.set_defaults(func=cmd_scene)

    v = sub.add_parser("serve", help="run the HTTP service",
                       description="The HTTP service, as `uvicorn service.app:app` runs it: "
                                   "settings from GUITAR_* environment variables "
                                   "(docs/service.md).")
    v.add_argument("--host", default="127.0.0.1", help="address to listen on (default 127.0.0.1)")
    v.add_argument("--port", type=int, default=8000, help="port (default 8000)")
    v.add_argument("--workers", type=int, metavar="N",
                   help="render worker processes (sets GUITAR_WORKERS; default one per core)")
    v.add_argument("--log-level", default="info",
                   choices=("critical", "error", "warning", "info", "debug"),
                   help="uvicorn's log level")
    v.set_defaults(func=cmd_serve)
    return parser


# ---- input -------------------------------------------------------------------------------


def _existing_file(path: str) -> Path:
    p = Path(path)
    if not p.exists():
        raise BadInput(f"{path}: no such file")
    if p.is_dir():
        raise BadInput(f"{path}: is a directory, not a file")
    if p.stat().st_size == 0:
        raise BadInput(f"{path}: the file is empty")
    return p


def _read_scene_json(p: Path) -> dict[str, Any]:
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise BadInput(f"{p}: not a text file, so not a scene .json") from None
    try:
        data = json.loads(text, parse_constant=_no_constant)
    except json.JSONDecodeError as e:
        raise BadInput(f"{p}: not valid JSON: {e.msg} at line {e.lineno} column {e.colno}") \
            from None
    except ValueError as e:  # NaN or Infinity
        raise BadInput(f"{p}: {e}") from None
    if not isinstance(data, dict):
        raise BadInput(f"{p}: a scene is a JSON object, not a {type(data).__name__}")
    return data


def _no_constant(name: str) -> NoReturn:
    raise ValueError(f"{name} is not a number a scene may hold")


def _score_options(args: argparse.Namespace) -> dict[str, Any]:
    opts: dict[str, Any] = {}
    if args.tracks is not None:
        opts["tracks"] = args.tracks
    if args.preset is not None:
        opts["presets"] = args.preset
    if args.tempo_scale is not None:
        opts["tempo_scale"] = args.tempo_scale
    if args.max_seconds is not None:
        opts["max_seconds"] = args.max_seconds
    if getattr(args, "all_instruments", False):
        opts["all_instruments"] = True
    return opts


_FLAGS = {"options.tracks": "--tracks", "options.presets": "--preset",
          "options.tempo_scale": "--tempo-scale", "options.max_seconds": "--max-seconds",
          "options.all_instruments": "--all-instruments"}


def _read_score(p: Path, args: argparse.Namespace) -> tuple[dict[str, Any], list[str]]:
    import engine

    try:
        result = engine.score_to_scene(p, **_score_options(args))
    except engine.ScoreError as e:
        msg = str(e)
        for option, flag in _FLAGS.items():  # the importer names its options; here they are flags
            msg = msg.replace(option, flag)
        raise BadInput(f"{p}: {msg}") from None
    except MemoryError:
        raise BadInput(f"{p}: the score needs more memory than there is") from None
    except Exception as e:  # a corrupt file reaching a path the importer's checks missed
        raise BadInput(f"{p}: could not be read as a score ({type(e).__name__}: {e})") from None
    return dict(result), list(getattr(result, "warnings", []))


def _set_preset(scene: dict[str, Any], preset: str) -> None:
    holders = scene["tracks"] if isinstance(scene.get("tracks"), list) else [scene]
    for h in holders:
        if isinstance(h, dict):
            guitar = h.get("guitar") if isinstance(h.get("guitar"), dict) else {}
            h["guitar"] = {**guitar, "preset": preset}


def _overrides(scene: dict[str, Any], args: argparse.Namespace) -> None:
    if args.quality is not None:
        scene["quality"] = args.quality
    if args.sample_rate is not None:
        scene["sample_rate"] = args.sample_rate
    if args.model is not None:
        set_model(scene, args.model)
    output = scene.get("output") if isinstance(scene.get("output"), dict) else {}
    if args.channels is not None:
        output["channels"] = args.channels
    if getattr(args, "normalize", None) is not None:
        output["normalize"] = args.normalize
    if getattr(args, "subtype", None) is not None:
        output["subtype"] = args.subtype
    if output:
        scene["output"] = output


def load_input(args: argparse.Namespace) -> tuple[dict[str, Any], list[str]]:
    """The scene (a dict in the JSON form) that INPUT and the options make, and the importer's
    warnings."""
    p = _existing_file(args.input)
    suffix = p.suffix.lower()
    if suffix in SCENE_SUFFIXES:
        scene, warnings = _read_scene_json(p), []
        if args.preset is not None:
            _set_preset(scene, args.preset)
        if args.max_seconds is not None:
            from engine import truncate

            truncate(scene, args.max_seconds)
        for flag, value in (("--tracks", args.tracks), ("--tempo-scale", args.tempo_scale)):
            if value is not None:
                raise BadInput(f"{flag} applies to scores (Guitar Pro, MusicXML, MIDI), not to a scene "
                               f".json like {p}")
    elif suffix in SCORE_SUFFIXES:
        scene, warnings = _read_score(p, args)
    else:
        raise BadInput(f"{p}: unknown input type {suffix or '(no suffix)'!r}: give a {INPUT_HELP}")
    _overrides(scene, args)
    return scene, warnings


def _event_tags() -> frozenset[str]:
    """The event ``type`` values of the scene schema: pydantic puts the tag of a union member
    into an error's location (``events.2.pluck.force``), which is not a field."""
    import engine

    tags: set[str] = set()

    def walk(node: Any) -> None:
        if isinstance(node, dict):
            tags.update(node.get("discriminator", {}).get("mapping", {}))
            for v in node.values():
                walk(v)
        elif isinstance(node, list):
            for v in node:
                walk(v)

    walk(engine.Scene.model_json_schema())
    return frozenset(tags)


def field_path(loc: tuple | list) -> str:
    """A dotted path such as ``events[2].force`` from a pydantic error location."""
    tags = _event_tags()
    path = ""
    for i, part in enumerate(loc):
        if isinstance(part, int):
            path += f"[{part}]"
        elif "[" in str(part) or (i and isinstance(loc[i - 1], int) and part in tags):
            continue
        else:
            path += f".{part}" if path else str(part)
    return path


def validate(scene: dict[str, Any], source: str) -> Any:
    """``engine.parse_scene``; an invalid scene becomes one line naming the field."""
    from pydantic import ValidationError

    import engine

    try:
        return engine.parse_scene(scene)
    except ValidationError as e:
        errors = e.errors()
        first = errors[0]
        msg = str(first.get("msg", "")).removeprefix("Value error, ")
        field = field_path(tuple(first.get("loc", ())))
        text = msg if not field or msg.startswith(field) else f"{field}: {msg}"
        more = f" (and {len(errors) - 1} more problems)" if len(errors) > 1 else ""
        raise BadInput(f"{source}: invalid scene: {text}{more}") from None


def _print_warnings(warnings: list[str], quiet: bool = False, mode: str = "summary") -> None:
    if quiet:
        return
    import engine

    warnings = engine.select_warnings(warnings, mode)
    for w in warnings[:MAX_WARNINGS_SHOWN]:
        print(f"warning: {w}", file=sys.stderr)
    if len(warnings) > MAX_WARNINGS_SHOWN:
        print(f"warning: and {len(warnings) - MAX_WARNINGS_SHOWN} more", file=sys.stderr)


# ---- commands ------------------------------------------------------------------------------


def _audio_format(path: str) -> str:
    suffix = Path(path).suffix.lower()
    if suffix not in AUDIO_FORMATS:
        raise BadInput(f"{path}: unknown audio suffix {suffix or '(none)'!r}: use .wav, .flac "
                       "or .ogg")
    return AUDIO_FORMATS[suffix]


def _writable(path: str) -> None:
    parent = Path(path).resolve().parent
    if not parent.is_dir():
        raise BadInput(f"{path}: the folder {parent} does not exist")
    if not os.access(parent, os.W_OK):
        raise BadInput(f"{path}: cannot write into {parent}")


def _progress(total_s: float, quiet: bool) -> Any:
    from tqdm import tqdm

    return tqdm(total=round(total_s, 3), unit="s", desc="preparing", file=sys.stderr,
                disable=quiet, dynamic_ncols=True, leave=True,
                bar_format="{desc} {percentage:3.0f}%|{bar}| {n:.1f}/{total:.1f} s of audio "
                           "[{elapsed}<{remaining}{postfix}]")


def scene_models(sc: Any) -> set[str]:
    """The string models a validated scene renders with (a track's own, or the scene's)."""
    tracks = getattr(sc, "tracks", None) or []
    return {t.model or sc.model for t in tracks} if tracks else {sc.model}


def prepare_kernels(sc: Any, quiet: bool) -> None:
    """Load the compiled kernels the scene's models need, or compile them (the first run on a
    machine, or after an upgrade), saying so, before the progress bar starts."""
    import engine

    models = scene_models(sc)
    if engine.kernels_cached(models):
        engine.prepare_kernels(models)
        return
    if not quiet:
        print(f"compiling kernels ({', '.join(sorted(models))}), first run only: about "
              f"{engine.compile_seconds(models)} s ...", file=sys.stderr, flush=True)
    seconds = engine.prepare_kernels(models)
    if not quiet:
        print(f"compiled in {seconds:.1f} s (kept in the cache for the next runs)",
              file=sys.stderr, flush=True)


# what the bar says while the calibration store computes a kind it does not hold yet
# (``engine.calibration_store.on_compute``); the others calibrate frets
CALIBRATING = {"decimation_taps": "designing the decimation filter",
               "waveguide_dispersion": "designing the strings' dispersion filters",
               "string_tuning": "tuning the strings"}

# frames per block of a command-line render: blocks as long as this (0.37 s at 44.1 kHz) keep the
# threads busy between the blocks' joins (a string's share of a block varies less), and the bar
# moves often enough
BLOCK_FRAMES = 16384


def render_audio(sc: Any, quiet: bool, jobs: int = 1, stems: Any = None) -> tuple[Any, float]:
    """The scene's audio (frames,) or (frames, 2), scaled as its ``output`` asks, rendered
    block by block on ``jobs`` threads with a progress bar; and the wall time of the render
    (the preparation included; loading or compiling the kernels, which ``prepare_kernels``
    reports on a line of its own when it compiles, not).  ``stems``: a
    ``cli.stems.StemWriter`` given each block of stems at the fixed gain as it comes."""
    import numpy as np

    import engine
    from engine import calibration_store

    rate = sc.sample_rate
    frames = engine.frame_count(sc)
    # written block by block into the output: a song holds no more than its audio
    audio = np.zeros((frames, 2) if sc.output.channels == 2 else frames)
    prepare_kernels(sc, quiet)
    # What the process holds now (numba's types and registries, the kernels, the modules) lives
    # until it exits: frozen out of the garbage collector's sight, it is walked neither by the
    # full collections the render's allocations trigger nor by the interpreter's at exit
    # (``python -m tools.startup``: the "exit" column)
    gc.freeze()
    t0 = time.perf_counter()
    with _progress(frames / rate, quiet) as bar:
        def calibrating(kind: str) -> None:
            what = CALIBRATING.get(kind, "calibrating frets")
            bar.set_description(f"{what} (first use of this guitar and quality)")

        calibration_store.on_compute(calibrating)
        try:
            # prepares the instruments: the bar says "preparing"
            blocks = engine.blocks(sc, BLOCK_FRAMES, jobs=jobs, stems=stems is not None)
        finally:
            calibration_store.on_compute(None)
        _print_warnings(blocks.warnings, quiet)
        bar.set_description("rendering")
        bar.reset(total=round(frames / rate, 3))  # the rate and time left count from here
        t1 = time.perf_counter()
        done = 0
        if stems is not None:
            stems.start(blocks.stem_layout)
        for block in blocks:
            if stems is not None:
                block, strings = block
                stems.write(strings)
            if not np.all(np.isfinite(block)):
                raise FloatingPointError("the audio holds non-finite samples")
            audio[done:done + len(block)] = block
            done += len(block)
            elapsed = time.perf_counter() - t1
            bar.set_postfix_str(f"{done / rate / elapsed:.2f}x real time" if elapsed else "")
            bar.update(round(done / rate, 3) - bar.n)
    if stems is not None and sc.output.normalize:
        # one gain for the mix and its stems, which puts the loudest at -1 dBFS (as engine.render
        # with stems): the stems are scaled into place with it
        velocity = np.divide(audio, engine.FIXED_GAIN, out=audio)  # held once (below)
        peak = max(engine.largest_magnitude(velocity), stems.peak / engine.FIXED_GAIN)
        gain = engine.output_gain(peak, True)
        stems.close(gain / engine.FIXED_GAIN)
        audio = np.multiply(velocity, gain, out=velocity)
    elif stems is not None:
        stems.close()  # written at the fixed gain as they came
    seconds = time.perf_counter() - t0
    if sc.output.normalize and stems is None:  # blocks come at the fixed gain; as engine.render
        # in place: a song's audio is held once (a copy of a long song's is a hundred megabytes,
        # which the system maps in page by page)
        velocity = np.divide(audio, engine.FIXED_GAIN, out=audio)
        audio = engine.to_output_scale(velocity, True, in_place=True)
    return audio, seconds


def write_audio(path: str, audio: Any, rate: int, fmt: str, subtype: str) -> None:
    """Write ``audio`` (samples, full scale 1) to ``path``, clipped to full scale in place."""
    import numpy as np
    import soundfile as sf

    if fmt == "flac":
        subtype = "PCM_16" if subtype == "PCM_16" else "PCM_24"
    elif fmt == "ogg":
        subtype = "VORBIS"
    sf.write(path, np.clip(audio, -1.0, 1.0, out=audio), rate, format=fmt.upper(),
             subtype=subtype)


def write_labels(path: str, sc: Any, title: str = "", metadata: dict | None = None) -> None:
    import engine

    engine.save_labels(engine.scene_labels(sc, title=title, metadata=metadata), path)


def cmd_render(args: argparse.Namespace) -> int:
    fmt = _audio_format(args.output)  # every check that needs no rendering comes first
    _writable(args.output)
    if args.labels:
        _writable(args.labels)
    scene, warnings = load_input(args)
    sc = validate(scene, args.input)
    _print_warnings(warnings, args.quiet, args.warnings)
    stems = None
    if args.stems:
        import engine
        from cli.stems import StemWriter, stems_folder

        folder = stems_folder(args.output)
        if folder.exists() and not folder.is_dir():
            raise BadInput(f"--stems: {folder} exists and is not a folder")
        # known now at the fixed gain; under normalize only once the whole mix is seen
        stems = StemWriter(folder, sc.sample_rate, fmt, sc.output.subtype,
                           None if sc.output.normalize else 1.0, engine.FIXED_GAIN)
    try:
        audio, seconds = render_audio(sc, args.quiet, args.jobs or _cores(), stems)
    except FloatingPointError as e:
        raise BadInput(f"{args.input}: the simulation became unstable ({e}); lower the forces or "
                       "use --quality high") from None
    except BaseException:
        if stems is not None:
            stems.abort()
        raise
    write_audio(args.output, audio, sc.sample_rate, fmt, sc.output.subtype)
    if args.labels:
        write_labels(args.labels, sc, Path(args.input).stem, {"input": Path(args.input).name})
    if not args.quiet:
        audio_s = len(audio) / sc.sample_rate
        speed = f", {audio_s / seconds:.2f}x real time" if seconds > 0 else ""
        labels = f" and {args.labels}" if args.labels else ""
        print(f"wrote {args.output}{labels}: {audio_s:.2f} s of audio in {seconds:.2f} s"
              f"{speed}", file=sys.stderr)
        if stems is not None:
            clipped = (f"; {stems.clipped} samples clipped at full scale (--no-normalize "
                       "or a lower force keeps them whole)") if stems.clipped else ""
            print(f"wrote {len(stems.paths)} stems in {stems.folder}{clipped}", file=sys.stderr)
    return 0


def cmd_scene(args: argparse.Namespace) -> int:
    if args.output != "-":
        _writable(args.output)
    scene, warnings = load_input(args)
    validate(scene, args.input)  # what is written is a scene /render accepts
    _print_warnings(warnings, mode=args.warnings)
    text = json.dumps(scene, indent=1, allow_nan=False) + "\n"
    if args.output == "-":
        sys.stdout.write(text)
    else:
        Path(args.output).write_text(text, encoding="utf-8")
        print(f"wrote {args.output}", file=sys.stderr)
    return 0


def cmd_serve(args: argparse.Namespace) -> int:
    if args.workers is not None:
        if args.workers < 1:
            raise BadInput(f"--workers: at least 1, not {args.workers}")
        os.environ["GUITAR_WORKERS"] = str(args.workers)
    if not 0 < args.port < 65536:
        raise BadInput(f"--port: 1..65535, not {args.port}")
    import uvicorn

    # the service writes its own JSON access line per request; uvicorn's would be a second one
    uvicorn.run("service.app:app", host=args.host, port=args.port, log_level=args.log_level,
                access_log=False)
    return 0


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else list(argv)
    if "batch" in argv and all(a.startswith("-") for a in argv[:argv.index("batch")]):
        from cli import batch  # its own parser: many inputs, Dask options

        return batch.main(argv[argv.index("batch") + 1:])
    parser = build_parser()
    args = parser.parse_args(argv)
    prog = f"guitar-synth {args.command}"
    try:
        return args.func(args)
    except BadInput as e:
        print(f"{prog}: error: {e}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    except Exception as e:
        if args.debug:
            raise
        print(f"{prog}: internal error: {type(e).__name__}: {e} (run with --debug for the "
              "traceback)", file=sys.stderr)
        return EXIT_INTERNAL


if __name__ == "__main__":
    sys.exit(main())
