"""One song on several cores: ``guitar-synth render --jobs N`` against ``--jobs 1``, both models.

    python -m benchmarks.threads                                  # Demo v5.gp5, 30 s, 3 rounds
    python -m benchmarks.threads --song 1390.mid --max-seconds 20 --rounds 5

Two figures per model:

* measured: the CLI run as a user runs it (``python -m cli.main render SONG -o x.wav --model M
  --jobs J``, warm caches), one process per render, ``--jobs 1`` and ``--jobs N`` interleaved for
  ``--rounds`` rounds; wall and CPU time of each process (``wait4``), the least wall time of each
  counted.  Both outputs are checked to be the same samples, bit for bit.  The speed-up is the
  one-thread wall time over the N-thread one; other processes on the machine take cores from
  the threads, so the load average is printed with it.
* schedule: what N idle cores would give, from the CPU time each string took in each block of a
  one-thread render (``time.thread_time``, which other processes do not inflate): the work
  outside the strings plus, per block, the longest thread's share when the strings are dealt to N
  threads most costly first, as ``engine.mix`` deals them (the GIL and the threads' start-up left
  out).  It says how far the blocks' joins and the songs' uneven strings keep a render from N
  times faster.
"""

from __future__ import annotations

import argparse
import heapq
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import soundfile as sf

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks.scores import corpus_file  # noqa: E402

MODELS = ("fdtd", "waveguide")


def cores() -> int:
    return len(os.sched_getaffinity(0))


def load() -> str:
    return " / ".join(f"{x:.2f}" for x in os.getloadavg())


def cli(song: Path, out: Path, model: str, jobs: int, max_seconds: float) -> tuple[float, float]:
    """Wall and CPU seconds of one CLI render (the whole process)."""
    argv = [sys.executable, "-m", "cli.main", "render", str(song), "-o", str(out), "-q",
            "--subtype", "FLOAT", "--model", model, "--max-seconds", f"{max_seconds:g}",
            "--jobs", str(jobs)]
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    t0 = time.perf_counter()
    proc = subprocess.Popen(argv, cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.DEVNULL)
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"{' '.join(argv)} failed")
    return wall, usage.ru_utime + usage.ru_stime


def measured(song: Path, model: str, jobs: int, max_seconds: float, rounds: int,
             tmp: Path) -> None:
    runs: dict[int, list[tuple[float, float]]] = {1: [], jobs: []}
    cli(song, tmp / "warm.wav", model, 1, 0.5)  # kernels and calibrations: not counted
    for _ in range(rounds):
        for j in runs:
            runs[j].append(cli(song, tmp / f"{j}.wav", model, j, max_seconds))
    same = sf.read(tmp / "1.wav")[0].tobytes() == sf.read(tmp / f"{jobs}.wav")[0].tobytes()
    (w1, c1), (wn, cn) = (min(runs[j]) for j in runs)
    print(f"| {model} | {w1:.2f} | {c1:.2f} | {wn:.2f} | {cn:.2f} | {w1 / wn:.2f}x | "
          f"{'yes' if same else 'NO'} |", flush=True)
    if not same:
        sys.exit(f"{model}: --jobs {jobs} gave other samples than --jobs 1")


def schedule(song: Path, model: str, jobs: int, max_seconds: float, block_frames: int) -> None:
    """The one-thread render's CPU time and what ``jobs`` idle cores would take (the docstring)."""
    import engine
    from cli.main import build_parser, load_input, validate
    from engine.mix import prepare

    args = build_parser().parse_args(["render", str(song), "-o", "x.wav", "--model", model,
                                      "--max-seconds", f"{max_seconds:g}"])
    sc = validate(load_input(args)[0], str(song))
    engine.prepare_kernels({model})
    mix = prepare(sc)
    costs: list[list[float]] = []
    for t in mix.tracks:
        inst = t.instrument

        def timed(voice, end, frames=inst.voice_frames):
            t0 = time.thread_time()
            y = frames(voice, end)
            costs[-1].append(time.thread_time() - t0)
            return y

        inst.voice_frames = timed
    c0 = time.thread_time()
    while mix.frame < mix.frames:
        costs.append([])
        mix.render_frames(min(block_frames, mix.frames - mix.frame))
    total = time.thread_time() - c0
    strings = sum(map(sum, costs))
    ideal = total - strings + sum(_makespan(c, jobs) for c in costs)
    per_voice = np.sum(costs, axis=0)
    print(f"| {model} | {len(mix.tracks)} / {len(mix.voices)} | {total:.2f} | "
          f"{total - strings:.2f} | {per_voice.max():.2f} | {ideal:.2f} | {total / ideal:.2f}x |",
          flush=True)


def _makespan(costs: list[float], threads: int) -> float:
    """The longest thread's time when ``costs`` are dealt to ``threads`` threads, most costly
    first, each to the thread free first."""
    free = [0.0] * threads
    for c in sorted(costs, reverse=True):
        heapq.heapreplace(free, free[0] + c)
    return max(free)


def main(argv: list[str] | None = None) -> None:
    from cli.main import BLOCK_FRAMES

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--song", default="Demo v5.gp5", help="a score: a path, or a name in the corpus")
    ap.add_argument("--max-seconds", type=float, default=30.0)
    ap.add_argument("--jobs", type=int, default=max(2, cores()), help="threads against one")
    ap.add_argument("--rounds", type=int, default=3, help="interleaved rounds (the least wall "
                    "time of each counts)")
    ap.add_argument("--models", nargs="+", choices=MODELS, default=list(MODELS))
    args = ap.parse_args(argv)
    song = corpus_file(args.song)
    print(f"{song.name}, the first {args.max_seconds:g} s; {cores()} cores this process may use; "
          f"load average (1 / 5 / 15 min) at the start: {load()}.\n")
    print(f"Measured: `cli.main render --jobs 1` and `--jobs {args.jobs}`, {args.rounds} rounds "
          "interleaved, the least wall time of each (seconds of the whole process).\n")
    print(f"| model | wall, 1 thread | CPU | wall, {args.jobs} threads | CPU | speed-up | "
          "same samples |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | --- |")
    with tempfile.TemporaryDirectory(prefix="guitar-threads-") as d:
        for model in args.models:
            measured(song, model, args.jobs, args.max_seconds, args.rounds, Path(d))
    print(f"\nLoad average after the measured runs: {load()}.\n")
    print(f"Schedule: a one-thread render in blocks of {BLOCK_FRAMES} frames (the CLI's), its "
          f"CPU seconds, and what {args.jobs} idle cores would take (the strings dealt per block, "
          "most costly first).\n")
    print(f"| model | tracks / strings | CPU, 1 thread | outside the strings | longest string | "
          f"{args.jobs} idle cores | speed-up |")
    print("| --- | --- | ---: | ---: | ---: | ---: | ---: |")
    for model in args.models:
        schedule(song, model, args.jobs, args.max_seconds, BLOCK_FRAMES)


if __name__ == "__main__":
    main()
