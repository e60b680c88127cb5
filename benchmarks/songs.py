"""Whole songs: CPU time and real-time factor of both string models and of FluidSynth on the same
notes, and the time a first render takes after install.

    python -m benchmarks.songs            # four whole songs, both models, FluidSynth, cold start
    python -m benchmarks.songs --quick    # the first 20 s of two songs, the cold start of fdtd only
    python -m benchmarks.songs --songs "Demo v5.gp5" --max-seconds 30 --no-cold
    python -m benchmarks.songs --cold-only   # a 2 s chord's first and second render, each model
    python -m benchmarks.songs --models waveguide --no-cold   # one model against FluidSynth

The songs are files nobody on this project wrote: the longest multi-track scores of the test
corpus (``make test-data``: PyGuitarPro's Guitar Pro files, music21's and miditoolkit's MIDI
files, in .cache/score-corpus).  Each renderer runs as a user runs it, one process per render,
pinned to one core, and is charged the CPU time of that whole process (user + system, from
``wait4``; children included): CPU time moves far less than wall time when other processes share
the machine.  With ``--repeat N`` a song is rendered in rounds, each renderer once a round, and
each renderer's least CPU time counts: on a host whose speed drifts over minutes the renderers
compared share its slow and its fast stretches.

* ``fdtd``: ``python -m cli.main render SONG -o out.wav --model fdtd --quality standard
  --all-instruments`` (every pitched track played, the orchestral MIDI files' too, as FluidSynth
  plays the same notes);
* ``waveguide``: the same with ``--model waveguide``;
* FluidSynth: the labels of the scene the score becomes (``engine.score.scene_labels``: the notes
  the models play, on the strings' pitches) written as a MIDI file on the General MIDI guitar
  program of each track's preset (``benchmarks.scores.write_midi``), rendered by Debian's
  ``fluidsynth -ni -F out.wav -r 44100 FluidR3_GM.sf2 song.mid``.

Both guitar-synth models run with warm caches (compiled kernels and fret calibrations: a first
run fills them, not counted), as FluidSynth runs with its SoundFont on disk.  The real-time factor
is the song's duration over the CPU time.  Each renderer's start-up (imports and loading the
kernels, or loading the SoundFont: the same process on a 50 ms note) is printed too, and the
per-song figures less it show what a song costs once a renderer is up (the service's workers are).

Cold start: a 2 s strummed C chord rendered through the CLI with an empty numba cache
(``NUMBA_CACHE_DIR``) and an empty calibration store (``GUITAR_CACHE_DIR``), as after a fresh
install, then once more with what that run left: wall and CPU time of each.  With both models,
also every kernel compiled into an empty cache as `make install` and a service's first start
compile them (``python -m engine.precompile --kernels-only``, not pinned: one child process per
model), with ``GUITAR_COMPILE_JOBS=1`` (one model after the other) and as shipped (at once).

The load on the machine (``os.getloadavg``) is printed before and after: figures taken on a
shared machine mean little without it.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks.scores import (  # noqa: E402
    SOUNDFONTS,
    Note,
    corpus_file,
    label_notes,
    write_midi,
)
from benchmarks.threads import cores, load  # noqa: E402
from engine import score  # noqa: E402

# The longest multi-track scores of the corpus: a Guitar Pro 5 demo (two electric guitars, an
# acoustic and a bass), Mozart's K. 525 first movement (five parts), and two two-part MIDI files.
SONGS = ("Demo v5.gp5", "k525MIDIMvt1.mid", "test09.mid", "1390.mid")
QUICK_SONGS = ("Demo v5.gp5", "1390.mid")
QUICK_SECONDS = 20.0
MODELS = ("fdtd", "waveguide")
QUALITY = "standard"
RATE = 44100

COLD_SCENE = {
    "duration": 2.0,
    "events": [{"type": "fret", "time": 0.0, "string": 5, "fret": 3},
               {"type": "fret", "time": 0.0, "string": 4, "fret": 2},
               {"type": "fret", "time": 0.0, "string": 2, "fret": 1},
               {"type": "strum", "time": 0.05, "direction": "down", "spread": 0.04}],
}
TINY_SCENE = {"duration": 0.05, "events": [{"type": "pluck", "time": 0.0, "string": 1}]}


@dataclass
class Run:
    wall: float
    cpu: float


def run_process(argv: list[str], env: dict | None = None, core: int | None = None) -> Run:
    """Run ``argv`` to its end (pinned to ``core``); its wall time and the CPU time of the
    process and its children (``wait4``'s rusage)."""
    pre = (lambda: os.sched_setaffinity(0, {core})) if core is not None else None
    with tempfile.TemporaryFile() as err:  # a file, not a pipe: a long stderr cannot block it
        t0 = time.perf_counter()
        proc = subprocess.Popen(argv, cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=err,
                                preexec_fn=pre)
        _, status, usage = os.wait4(proc.pid, 0)
        wall = time.perf_counter() - t0
        proc.returncode = os.waitstatus_to_exitcode(status)
        if proc.returncode != 0:
            err.seek(0)
            text = err.read().decode(errors="replace")
            sys.exit(f"{' '.join(argv)} failed ({proc.returncode}):\n{text[-2000:]}")
    return Run(wall, usage.ru_utime + usage.ru_stime)


def engine_env(numba_cache: Path | None = None, calibrations: Path | None = None) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    if numba_cache is not None:
        env["NUMBA_CACHE_DIR"] = str(numba_cache)
    if calibrations is not None:
        env["GUITAR_CACHE_DIR"] = str(calibrations)
    return env


def cli_render(source: Path, out: Path, model: str, env: dict, core: int | None,
               max_seconds: float | None = None) -> Run:
    argv = [sys.executable, "-m", "cli.main", "render", str(source), "-o", str(out), "-q",
            "--model", model, "--quality", QUALITY, "--all-instruments"]
    if max_seconds is not None:
        argv += ["--max-seconds", f"{max_seconds:g}"]
    return run_process(argv, env, core)


def fluidsynth(midi: Path, wav: Path, soundfont: str, core: int | None) -> Run:
    return run_process(["fluidsynth", "-ni", "-q", "-F", str(wav), "-r", str(RATE), soundfont,
                        str(midi)], None, core)


def best(runs: list[Run]) -> Run:
    return min(runs, key=lambda r: r.cpu)


# ---- songs ----------------------------------------------------------------------------------


@dataclass
class Song:
    name: str
    tracks: int
    presets: str
    notes: int
    seconds: float
    cpu: dict[str, float]


def song(name: str, max_seconds: float | None, soundfont: str | None, core: int | None,
         repeat: int, tmp: Path, models: tuple[str, ...] = MODELS) -> Song:
    path = corpus_file(name)
    opts = {"all_instruments": True, **({"max_seconds": max_seconds} if max_seconds else {})}
    scene = score.score_to_scene(path, **opts)
    presets = [t["guitar"]["preset"] for t in scene["tracks"]]
    notes = label_notes(score.scene_labels(scene))
    env = engine_env()
    midi = tmp / "song.mid"
    if soundfont is not None:
        write_midi(notes, presets, midi)
    # in rounds, each renderer once a round: a machine whose speed drifts over minutes (a shared
    # host) slows every renderer alike, not the one that happened to run then
    runs: dict[str, list[Run]] = {}
    for i in range(max(repeat, 3) if soundfont is not None else repeat):
        if i < repeat:
            for model in models:
                runs.setdefault(model, []).append(
                    cli_render(path, tmp / "song.wav", model, env, core, max_seconds))
        if soundfont is not None:
            runs.setdefault("fluidsynth", []).append(
                fluidsynth(midi, tmp / "song_fs.wav", soundfont, core))
    cpu = {name: best(r).cpu for name, r in runs.items()}
    kinds = sorted(set(presets), key=presets.index)
    return Song(path.name, len(presets), ", ".join(kinds), len(notes), float(scene["duration"]),
                cpu)


def startup(soundfont: str | None, core: int | None, tmp: Path,
            models: tuple[str, ...] = MODELS) -> dict[str, float]:
    """CPU time of each renderer's process on a 50 ms note (best of 3): imports and loading the
    compiled kernels, or loading the SoundFont."""
    scene = tmp / "tiny.json"
    scene.write_text(json.dumps(TINY_SCENE))
    env = engine_env()
    out = {}
    for model in models:
        out[model] = best([cli_render(scene, tmp / "tiny.wav", model, env, core)
                           for _ in range(3)]).cpu
    if soundfont is not None:
        write_midi([Note(0, 0.0, 0.05, 64, ())], ["steel-acoustic"], tmp / "tiny.mid")
        out["fluidsynth"] = best([fluidsynth(tmp / "tiny.mid", tmp / "tiny_fs.wav", soundfont, core)
                                  for _ in range(3)]).cpu
    return out


def print_songs(songs: list[Song], start: dict[str, float], renderers: list[str]) -> None:
    label = {"fdtd": f"finite difference ({QUALITY})", "waveguide": "waveguide",
             "fluidsynth": "FluidSynth"}
    head = " | ".join(f"{label[r]}: CPU s | x real time" for r in renderers)
    print(f"| song | tracks | notes | audio s | {head} |")
    print("| --- | ---: | ---: | ---: |" + " ---: | ---: |" * len(renderers))
    total_s = sum(s.seconds for s in songs)
    totals = {r: sum(s.cpu[r] for s in songs) for r in renderers}
    for s in songs:
        cells = " | ".join(f"{s.cpu[r]:.2f} | {s.seconds / s.cpu[r]:.1f}" for r in renderers)
        print(f"| {s.name} ({s.presets}) | {s.tracks} | {s.notes} | {s.seconds:.1f} | {cells} |")
    if len(songs) > 1:
        cells = " | ".join(f"{totals[r]:.2f} | {total_s / totals[r]:.1f}" for r in renderers)
        print(f"| all | | {sum(s.notes for s in songs)} | {total_s:.1f} | {cells} |")
    cells = " | ".join(f"{start[r]:.2f} | " for r in renderers)
    print(f"| start-up (a 50 ms note) | | | | {cells} |")
    print()
    if "fluidsynth" in renderers:
        print("CPU time against FluidSynth's (all songs; whole processes, and less each "
              "renderer's start-up once per song):\n")
        print("| renderer | whole processes | less start-up |")
        print("| --- | ---: | ---: |")
        n = len(songs)
        fs_net = max(totals["fluidsynth"] - n * start["fluidsynth"], 1e-9)
        for r in renderers[:-1]:
            net = totals[r] - n * start[r]
            print(f"| {label[r]} | {totals[r] / totals['fluidsynth']:.2f}x | "
                  f"{net / fs_net:.2f}x |")
        print()


# ---- cold start -----------------------------------------------------------------------------


def cold_start(models: tuple[str, ...], core: int | None, tmp: Path) -> None:
    scene = tmp / "cold.json"
    scene.write_text(json.dumps(COLD_SCENE))
    print("| first render of a 2 s chord through the CLI | wall s | CPU s |")
    print("| --- | ---: | ---: |")
    for model in models:
        numba, cal = Path(tempfile.mkdtemp(dir=tmp)), Path(tempfile.mkdtemp(dir=tmp))
        env = engine_env(numba, cal)
        cold = cli_render(scene, tmp / "cold.wav", model, env, core)
        warm = cli_render(scene, tmp / "cold.wav", model, env, core)
        print(f"| {model}, empty caches (after install) | {cold.wall:.1f} | {cold.cpu:.1f} |")
        print(f"| {model}, the second time | {warm.wall:.1f} | {warm.cpu:.1f} |")
        shutil.rmtree(numba, ignore_errors=True)
        shutil.rmtree(cal, ignore_errors=True)
    if len(models) > 1:  # what `make install` and a service's first start wait for
        for jobs in ("1", ""):
            numba = Path(tempfile.mkdtemp(dir=tmp))
            env = {**engine_env(numba), "GUITAR_COMPILE_JOBS": jobs}
            run = run_process([sys.executable, "-m", "engine.precompile", "--kernels-only"], env,
                              None)
            how = "one model at a time" if jobs else f"the models at once on {cores()} cores"
            print(f"| every kernel, empty cache (`engine.precompile --kernels-only`), {how} "
                  f"| {run.wall:.1f} | {run.cpu:.1f} |")
            shutil.rmtree(numba, ignore_errors=True)
    print()


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true",
                    help=f"the first {QUICK_SECONDS:g} s of {', '.join(QUICK_SONGS)}; the cold "
                         "start of the finite-difference model only")
    ap.add_argument("--songs", nargs="+", metavar="SCORE",
                    help=f"scores (a path, or a name in the corpus; default {', '.join(SONGS)})")
    ap.add_argument("--max-seconds", type=float, metavar="S", help="play only the first S s")
    ap.add_argument("--repeat", type=int, default=1, help="renders per song and model, in "
                    "rounds with FluidSynth's (the least CPU time counts; FluidSynth always at "
                    "least 3)")
    ap.add_argument("--no-cold", action="store_true", help="leave the cold start out")
    ap.add_argument("--models", nargs="+", choices=MODELS, default=list(MODELS),
                    help="the string models to run (default: both)")
    ap.add_argument("--cold-only", action="store_true", help="only the cold start (and the "
                    "second render after it), of every model")
    ap.add_argument("--all-cores", action="store_true", help="do not pin renders to one core")
    args = ap.parse_args(argv)
    models = tuple(args.models)
    songs = args.songs or (QUICK_SONGS if args.quick else SONGS)
    max_seconds = args.max_seconds or (QUICK_SECONDS if args.quick else None)
    core = None if args.all_cores else min(os.sched_getaffinity(0))
    soundfont = next((s for s in SOUNDFONTS if Path(s).exists()), None)
    if shutil.which("fluidsynth") is None:
        soundfont = None
    renderers = [*models, "fluidsynth"] if soundfont else list(models)
    print(f"Load average (1 / 5 / 15 min) at the start: {load()} on {os.cpu_count()} cores; "
          f"renders pinned to {'no core' if core is None else f'core {core}'}.\n")
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="guitar-songs-") as d:
        tmp = Path(d)
        if args.cold_only:
            cold_start(models, core, tmp)
            return
        # fill the caches (kernels, the calibrations of every preset the songs use): not counted
        for name in songs:
            for model in models:
                cli_render(corpus_file(name), tmp / "warm.wav", model, engine_env(), core, 0.5)
        start = startup(soundfont, core, tmp, models)
        results = [song(name, max_seconds, soundfont, core, args.repeat, tmp, models)
                   for name in songs]
        cut = f", the first {max_seconds:g} s of each" if max_seconds else ", whole"
        fs = (f"FluidSynth {_fs_version()} with {Path(soundfont).name}" if soundfont
              else "FluidSynth not installed: `make bench-tools`")
        print(f"CPU seconds of each render's whole process{cut} (`python -m cli.main render "
              f"--quality {QUALITY} --model M`; {fs}); x real time = audio seconds / CPU "
              "seconds.\n")
        print_songs(results, start, renderers)
        if not args.no_cold:
            cold_start(models[:1] if args.quick else models, core, tmp)
    print(f"Load average at the end: {load()}; the benchmark took "
          f"{time.perf_counter() - t0:.0f} s of wall time.")


def _fs_version() -> str:
    out = subprocess.run(["fluidsynth", "--version"], capture_output=True, text=True).stdout
    first = out.splitlines()[0] if out else ""
    return first.split()[-1] if first else ""


if __name__ == "__main__":
    main()
