"""One song on several cores: ``guitar-synth render --jobs N`` against ``--jobs 1``, both models.

    python -m benchmarks.threads                                  # Demo v5.gp5, 30 s, 3 rounds
    python -m benchmarks.threads --song 1390.mid --max-seconds 20 --rounds 5
    python -m benchmarks.threads --machine-only     # only the first figure

Three figures per model:

* machine: what this machine gives two independent one-thread renders at once (each pinned to a
  core of its own) against one alone: the ceiling of any one render's speed-up on two threads,
  which cores that share a physical core or a busy host lower;

* measured: the CLI run as a user runs it (``python -m cli.main render SONG -o x.wav --model M
  --all-instruments --jobs J``, the scene ``benchmarks.songs`` renders, warm caches), one process
  per render, ``--jobs 1`` and ``--jobs N`` interleaved for ``--rounds`` rounds; wall and CPU
  time of each process (``wait4``), the least wall time of each counted.  Both outputs are
  checked to be the same samples, bit for bit.  The speed-up is the one-thread wall time over the
  N-thread one; other processes on the machine take cores from the threads, so the load average
  is printed with it.
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


def _argv(song: Path, out: Path, model: str, jobs: int, max_seconds: float) -> list[str]:
    return [sys.executable, "-m", "cli.main", "render", str(song), "-o", str(out), "-q",
            "--subtype", "FLOAT", "--model", model, "--max-seconds", f"{max_seconds:g}",
            "--all-instruments", "--jobs", str(jobs)]


def _start(argv: list[str], core: int | None = None) -> tuple[subprocess.Popen, float]:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    pre = (lambda: os.sched_setaffinity(0, {core})) if core is not None else None
    t0 = time.perf_counter()
    return subprocess.Popen(argv, cwd=ROOT, env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, preexec_fn=pre), t0


def _wait(proc: subprocess.Popen, t0: float) -> tuple[float, float]:
    err = proc.stderr.read().decode(errors="replace").strip()  # (a render writes little there)
    proc.stderr.close()
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - t0
    if os.waitstatus_to_exitcode(status) != 0:
        last = err.splitlines()[-1] if err else "no message"
        sys.exit(f"{' '.join(map(str, proc.args))} failed: {last}")
    return wall, usage.ru_utime + usage.ru_stime


def cli(song: Path, out: Path, model: str, jobs: int, max_seconds: float) -> tuple[float, float]:
    """Wall and CPU seconds of one CLI render (the whole process)."""
    return _wait(*_start(_argv(song, out, model, jobs, max_seconds)))


def machine(song: Path, model: str, max_seconds: float, rounds: int, tmp: Path) -> None:
    """What this machine gives two processes at once: a one-thread render pinned to the first
    core alone, and two of them at once, one on each of the first two cores (interleaved rounds,
    least wall times).  Two cores that share nothing do both in the time of one; where they share
    (hyperthreads of one physical core, a host that time-slices its virtual CPUs, memory
    bandwidth), the pair takes longer, and no thread schedule in one render can beat that."""
    argv = _argv(song, tmp / "m.wav", model, 1, max_seconds)
    alone, pair = [], []
    for _ in range(rounds):
        alone.append(_wait(*_start(argv, 0))[0])
        started = [_start(_argv(song, tmp / f"m{c}.wav", model, 1, max_seconds), c)
                   for c in (0, 1)]
        pair.append(max(_wait(*s)[0] for s in started))
    a, b = min(alone), min(pair)
    print(f"| {model} | {a:.2f} | {b:.2f} | {2 * a / b:.2f}x |", flush=True)


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
                                      "--max-seconds", f"{max_seconds:g}", "--all-instruments"])
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
    ap.add_argument("--machine-only", action="store_true",
                    help="only what the machine gives two one-thread renders at once")
    args = ap.parse_args(argv)
    song = corpus_file(args.song)
    print(f"{song.name}, the first {args.max_seconds:g} s; {cores()} cores this process may use; "
          f"load average (1 / 5 / 15 min) at the start: {load()}.\n")
    if cores() >= 2:
        print("Machine: `--jobs 1` pinned to core 0 alone, and two of them at once on cores 0 and "
              f"1 ({args.rounds} rounds interleaved, the least wall time of each; the pair's is "
              "its slower one's). The throughput is what two cores give two independent "
              "renders: the ceiling of one render's speed-up on two threads.\n")
        print("| model | wall, alone | wall, two at once | throughput |")
        print("| --- | ---: | ---: | ---: |")
        with tempfile.TemporaryDirectory(prefix="guitar-threads-") as d:
            cli(song, Path(d) / "warm.wav", args.models[0], 1, 0.5)  # not counted
            for model in args.models:
                machine(song, model, args.max_seconds, args.rounds, Path(d))
        print()
    if args.machine_only:
        return
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
