"""Instructions of whole-song renders, counted by valgrind: a kernel's cost on real music in a
measure that does not move with the machine's load.

    python -m tools.song_instructions FILE [FILE ...] [--model waveguide] [--max-seconds S]
    python -m tools.song_instructions FILE [FILE ...] --windows    # what holds the general step

Each FILE (a Guitar Pro or MIDI file, or a scene .json) becomes the scene that
``guitar-synth render FILE --model MODEL --all-instruments [--max-seconds S]`` renders
(``tools.song_scene``: ``benchmarks.songs``' command), and is rendered block by block as the CLI
does (``engine.blocks``).  As in ``tools.instructions``
(whose pinned CPU, cache and markers this reuses), one child process renders the first half
second of every scene natively to load the compiled kernels, then, under callgrind, prepares and
renders each scene with ``os.getppid()`` markers around the render: the counts are the render's
instructions (the engine's Python around the kernels included; parsing, preparing and loading
the kernels not).

Per string-second: the render's instructions over the scene's strings times its duration (every
string of every track, sounding or not), and over the string-seconds the strings actually ran
(the steps the waveguide kernel ran: not stopped by the decay stop), which a native run of the
same child counts, with the waveguide kernel's own counts of where its steps went: the general
step, plain runs (``kernel._plain``, steady junctions included) and asleep (``voice._sleep``),
as shares of all the strings' steps.  callgrind cannot split the count between the kernel's
functions: numba's compiled code has no symbols it can read.

``--windows`` (no valgrind, the waveguide only): the share of string-steps that lie in some
junction's window (from its onset to the end of its leak, ``pluck.LEAK_HZ``), where the kernel
takes its general step, split by what holds it there: a pulse (a pluck's, a tap's force), a
steady contact with no pulse (a damp until the string's next event, a palm mute, a harmonic
touch), or only a released junction's leak; and the junctions per string and in force per step.
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
from pathlib import Path

from tools.instructions import CPU_NAME, callgrind_marked, pinned_env

CHILD = r"""
import json, os, sys
import engine
from engine.mix import prepare
import engine.waveguide.voice as wv
from tools.song_scene import song_scene
jobs = json.loads(sys.argv[1])
def scene_of(path, model, seconds):
    return song_scene(path, seconds, model)
ran = [0]  # string-steps the waveguide kernel ran (a native run only: counting costs)
if os.environ.get("SONG_COUNT_STEPS") == "1":
    entry = wv.entry_point
    def counting(dispatcher, args):
        fn = entry(dispatcher, args)
        def run(*a):
            n = fn(*a)
            ran[0] += max(n, 0)
            return n
        return run
    wv.entry_point = counting
for j in jobs:  # load the kernels (not counted)
    for _ in engine.blocks(scene_of(j["path"], j["model"], 0.5)):
        pass
scenes = [scene_of(j["path"], j["model"], j["seconds"]) for j in jobs]
info = []
for sc in scenes:
    mix = prepare(sc)  # as engine.blocks does
    ran[0] = 0
    os.getppid()  # dump: everything before this render
    for _ in mix.blocks(4096):
        pass
    os.getppid()  # dump: this render
    wg = [v for v in mix.voices if hasattr(v, "steps_slept")]
    info.append({"duration": mix.frames / sc.sample_rate, "ran": ran[0],
                 "rate": sc.sample_rate, "tracks": len(mix.tracks),
                 "strings": len(mix.voices),
                 "general": sum(int(v.st["general"]) for v in wg),
                 "plain": sum(int(v.st["plain"]) for v in wg),
                 "slept": sum(v.steps_slept for v in wg)})
print("SONGINFO " + json.dumps(info))
"""

def measure(jobs: list[dict]) -> tuple[list[int], list[dict]]:
    """(instructions of each job's render, its scene's facts)."""
    env = pinned_env()
    argv = [sys.executable, "-c", CHILD, json.dumps(jobs)]
    native = subprocess.run(argv, env={**env, "SONG_COUNT_STEPS": "1"}, capture_output=True,
                            text=True)
    if native.returncode != 0:
        sys.exit(f"the native run failed:\n{native.stderr[-3000:]}")
    info = json.loads(native.stdout.split("SONGINFO ", 1)[1])
    # a marker before and after each job's render: the stretches alternate between the set-up
    # before a render and the render itself, whose counts are every other one
    counts = callgrind_marked(argv, env, 2 * len(jobs) - 1)[::2]
    return counts, info


def windows(path: str, seconds: float | None) -> str:
    """``--windows``' line for one file."""
    import math

    import numpy as np

    from engine.mix import prepare
    from engine.waveguide.pluck import LEAK_HZ
    from tools.song_scene import song_scene

    sc = song_scene(path, seconds)
    mix = prepare(sc)
    frames = mix.frames
    tot = dict.fromkeys(("any", "pulse", "steady", "leak", "in_force"), 0)
    for v in mix.voices:
        tail = int(8.0 * v.rate / (2.0 * math.pi * LEAK_HZ))  # as ``kernel.run_block``
        held = {k: np.zeros(frames, bool) for k in ("any", "pulse", "steady", "leak")}
        count = np.zeros(frames + 1, np.int64)
        for sl, on, off, rel in zip(v.timeline.slots, v.js_on, v.js_off, v.js_rel, strict=True):
            a, b, c = max(int(on), 0), min(int(off + rel), frames), min(int(off + rel + tail), frames)
            if a >= c:
                continue
            held["any"][a:c] = True
            held["leak"][b:c] = True
            held["pulse" if sl.length > 0 else "steady"][a:b] = True
            count[a] += 1
            count[c] -= 1
        tot["any"] += int(held["any"].sum())
        tot["pulse"] += int(held["pulse"].sum())
        tot["steady"] += int((held["steady"] & ~held["pulse"]).sum())
        tot["leak"] += int((held["leak"] & ~held["pulse"] & ~held["steady"]).sum())
        tot["in_force"] += int(np.cumsum(count)[:frames].sum())
    steps = frames * len(mix.voices)
    nj = sum(len(v.js_on) for v in mix.voices)
    return (f"{Path(path).name}: {len(mix.voices)} strings, {frames / sc.sample_rate:.1f} s: "
            f"string-steps in a junction's window {tot['any'] / steps:.1%} (a pulse "
            f"{tot['pulse'] / steps:.1%}, a steady contact and no pulse {tot['steady'] / steps:.1%}, "
            f"only a released junction's leak {tot['leak'] / steps:.1%}); junctions per string "
            f"{nj / max(len(mix.voices), 1):.0f}, in force per step in a window "
            f"{tot['in_force'] / max(tot['any'], 1):.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", metavar="FILE")
    ap.add_argument("--model", default="waveguide", choices=["fdtd", "waveguide"])
    ap.add_argument("--max-seconds", type=float, default=None)
    ap.add_argument("--json", action="store_true", help="one JSON line per file instead")
    ap.add_argument("--windows", action="store_true",
                    help="no valgrind: what holds the waveguide's strings in the general step")
    args = ap.parse_args()
    if args.windows:
        for f in args.files:
            print(windows(f, args.max_seconds))
        return
    jobs = [{"path": str(Path(f).resolve()), "model": args.model, "seconds": args.max_seconds}
            for f in args.files]
    counts, info = measure(jobs)
    print(f"model {args.model}; kernels built for {CPU_NAME} (callgrind); render only "
          f"(block by block, as the CLI)")
    for j, n, i in zip(jobs, counts, info, strict=True):
        name = Path(j["path"]).name
        ss = (i["strings"] or 0) * i["duration"]
        ran_s = i["ran"] / i["rate"]
        row = {"file": name, "seconds": round(i["duration"], 2), "tracks": i["tracks"],
               "strings": i["strings"], "instructions": n,
               "M_per_audio_s": round(n / i["duration"] / 1e6, 1),
               "M_per_string_s": round(n / ss / 1e6, 2) if ss else None,
               "ran_string_s": round(ran_s, 1),
               "M_per_ran_string_s": round(n / ran_s / 1e6, 2) if ran_s else None,
               "steps": {k: round(i[k] / max(ss * i["rate"], 1), 4)
                         for k in ("general", "plain", "slept")}}
        if args.json:
            print(json.dumps(row))
            continue
        print(f"{name}: {row['seconds']} s, {row['tracks']} tracks, {row['strings']} strings: "
              f"{n / 1e6:.1f} M instructions, {row['M_per_audio_s']} M per s of audio, "
              f"{row['M_per_string_s']} M per string-second, {row['M_per_ran_string_s']} M per "
              f"string-second run ({row['ran_string_s']} string-s run); string-steps: general "
              f"{row['steps']['general']:.1%}, plain {row['steps']['plain']:.1%}, asleep "
              f"{row['steps']['slept']:.1%}")


if __name__ == "__main__":
    main()
