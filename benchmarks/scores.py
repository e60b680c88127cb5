"""Scores rendered: speed against FluidSynth, and whether an independent pitch tracker hears the
labelled notes.

    python -m benchmarks.scores                          # the default run: a few minutes
    python benchmarks/scores.py                          # the default run: a few minutes
    python benchmarks/scores.py --speed "Demo v5.gp5"    # a whole Guitar Pro song (minutes more)

Needs the score corpus (`make test-data`: PyGuitarPro's test files and the MIDI files of music21
and miditoolkit in .cache/score-corpus) and, for the comparison, Debian's `fluidsynth` with
`fluid-soundfont-gm` (`make bench-tools` installs them when root).

Speed: a whole multi-track score is imported (``engine.score.score_to_scene``) and rendered
(``engine.render_result``) on one core, after ``engine.warmup()``; the same notes (the labels of
the rendered scene: ``engine.score.scene_labels``) are written as a MIDI file with mido, one
channel per track on the General MIDI guitar program of its preset, and rendered by
`fluidsynth -ni -F out.wav -r 44100 SOUNDFONT file.mid` pinned to the same core.  FluidSynth's
time is given whole and less the time it takes on a MIDI file of one short note (start-up and
loading the SoundFont), which is its cost per second of music.

Accuracy: monophonic score parts are rendered and run through librosa's pYIN (Mauch & Dixon 2014,
an HMM over YIN candidates) and librosa's onset detector; runs of frames on one semitone, split at
detected onsets, are the transcribed notes.  ``mir_eval.transcription`` compares them with the
labels: onset within 50 ms and pitch within 50 cents (offsets ignored).  Then every label held
long enough (``HELD_S``) and played plainly (no bend, vibrato, slide, harmonic, dead or trill) is
measured alone: the median of librosa's YIN (continuous, parabolic interpolation; pYIN's own
output lies on a 10-cent grid) from ``SETTLE_S`` after its attack to ``MEASURE_S`` later, against
the label's pitch; it passes within 10 cents.  The same measurement is made on FluidSynth's
rendering of the same notes, which shows what the tracker itself misses.
"""

from __future__ import annotations

import argparse
import os
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import engine  # noqa: E402
from engine import score  # noqa: E402

CORPUS = ROOT / ".cache" / "score-corpus"
SOUNDFONTS = ("/usr/share/sounds/sf2/FluidR3_GM.sf2", "/usr/share/sounds/sf2/default-GM.sf2")
RATE = 44100

# General MIDI programs (0-based) for each preset, the sounds FluidSynth plays the notes with
GM_PROGRAM = {"nylon-classical": 24, "steel-acoustic": 25, "electric": 27, "bass": 33}

DEFAULT_SPEED = "midi/test02.mid"  # four parts, 19.5 s: the whole score in about a minute
DEFAULT_ACCURACY = ["midi/test06.mid", "gp/Duration.gp3"]

HELD_S = 0.2  # a label at least this long is measured for its pitch
SETTLE_S = 0.06  # ... from this long after its attack (the pitch glide of a hard pluck settles)
MEASURE_S = 0.25  # ... over at most this long
# articulations (engine.score.labels) that move a note's pitch away from its label's, or leave none
NOT_PLAIN = {"bend", "prebend", "vibrato", "slide_in", "slide_out", "arrival", "dead",
             "palm_mute"}


def plain(n: Note) -> bool:
    return not any(a in NOT_PLAIN or a.startswith("harmonic") for a in n.articulations)


def corpus_file(name: str) -> Path:
    p = Path(name)
    if p.exists():
        return p
    for candidate in (CORPUS / name, *CORPUS.glob(f"*/{name}")):
        if candidate.exists():
            return candidate
    sys.exit(f"{name}: not found (run `make test-data` for the score corpus in {CORPUS})")


def one_core() -> int:
    """Pin this process (and the FluidSynth it starts) to one core; returns the core."""
    core = min(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {core})
    return core


# ---- labels -> MIDI -> FluidSynth ---------------------------------------------------------------


@dataclass
class Note:
    track: int
    start: float
    end: float
    pitch: float  # MIDI, fractional
    articulations: tuple[str, ...]
    string: int = 0  # 1 = highest
    fret: int = 0


def label_notes(jam) -> list[Note]:
    notes = []
    for ann in jam.search(namespace="note_midi"):
        for obs, info in zip(ann.data, ann.sandbox.notes, strict=True):
            notes.append(Note(int(ann.sandbox.track), float(obs.time),
                              float(obs.time + obs.duration), float(obs.value),
                              tuple(info.get("articulations") or ()),
                              int(ann.sandbox.string), int(info.get("fret") or 0)))
    return sorted(notes, key=lambda n: (n.start, n.pitch))


def write_midi(notes: list[Note], presets: list[str], path: Path) -> None:
    """The notes as a type-1 MIDI file: one track and channel per scene track (channel 10, the
    percussion channel, skipped), its preset's GM program, velocity 96, pitch rounded."""
    import mido

    tpb, tempo = 480, 500_000  # 120 bpm: 960 ticks a second
    per_s = tpb * 1e6 / tempo
    mid = mido.MidiFile(type=1, ticks_per_beat=tpb)
    meta = mido.MidiTrack([mido.MetaMessage("set_tempo", tempo=tempo, time=0)])
    mid.tracks.append(meta)
    for i, preset in enumerate(presets):
        channel = i if i < 9 else i + 1
        if channel > 15:
            raise ValueError("more than 15 tracks")
        msgs = [(0, 0, mido.Message("program_change", channel=channel,
                                    program=GM_PROGRAM.get(preset, 25)))]
        for n in notes:
            if n.track == i:
                p = int(round(n.pitch))
                msgs.append((round(n.start * per_s), 2, mido.Message(
                    "note_on", channel=channel, note=p, velocity=96)))
                msgs.append((round(n.end * per_s), 1, mido.Message(
                    "note_off", channel=channel, note=p, velocity=0)))
        msgs.sort(key=lambda m: (m[0], m[1]))
        track, now = mido.MidiTrack(), 0
        for tick, _, msg in msgs:
            track.append(msg.copy(time=tick - now))
            now = tick
        mid.tracks.append(track)
    mid.save(path)


def fluidsynth(midi: Path, wav: Path, soundfont: str, core: int) -> tuple[float, float]:
    """Render with the fluidsynth command; returns its wall and CPU time."""
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    subprocess.run(["fluidsynth", "-ni", "-q", "-F", str(wav), "-r", str(RATE), soundfont,
                    str(midi)], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                   preexec_fn=lambda: os.sched_setaffinity(0, {core}))
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)


def read_mono(path: Path) -> np.ndarray:
    import soundfile as sf

    x, rate = sf.read(path, dtype="float64", always_2d=True)
    assert rate == RATE, rate
    return x.mean(axis=1)


# ---- speed ----------------------------------------------------------------------------------


def speed(path: Path, quality: str, soundfont: str | None, core: int, tmp: Path) -> None:
    t0 = time.perf_counter()
    scene = score.score_to_scene(path, all_instruments=True)
    import_s = time.perf_counter() - t0
    scene["quality"] = quality
    tracks = scene["tracks"]
    n_events = sum(len(t["events"]) for t in tracks)
    c0 = time.process_time()
    result = engine.render_result(scene)
    cpu = time.process_time() - c0
    audio_s = len(result.audio) / RATE
    assert np.all(np.isfinite(result.audio))
    notes = label_notes(score.scene_labels(scene))
    print(f"## Speed: {path.name}, whole score, on one core (core {core})\n")
    print(f"{len(tracks)} tracks ({', '.join(t['guitar']['preset'] for t in tracks)}), "
          f"{len(notes)} notes, {n_events} events, {audio_s:.1f} s of audio; import "
          f"{import_s:.2f} s\n")
    print("Times real time = audio seconds / seconds taken; CPU time is the fairer figure on a "
          "machine others share.\n")
    print("| renderer | wall s | CPU s | times real time (wall) | times real time (CPU) |")
    print("| --- | ---: | ---: | ---: | ---: |")
    print(f"| guitar-synth, quality {quality} | {result.seconds:.2f} | {cpu:.2f} | "
          f"{audio_s / result.seconds:.2f} | {audio_s / cpu:.2f} |")
    if soundfont is None:
        print("| FluidSynth | not installed (`make bench-tools`) | | | |")
        return
    midi = tmp / "speed.mid"
    write_midi(notes, [t["guitar"]["preset"] for t in tracks], midi)
    write_midi([Note(0, 0.0, 0.05, 64, ())], ["steel-acoustic"], tmp / "empty.mid")
    startup = min((fluidsynth(tmp / "empty.mid", tmp / "empty.wav", soundfont, core)
                   for _ in range(3)), key=lambda x: x[1])
    wall, fs_cpu = min((fluidsynth(midi, tmp / "speed_fs.wav", soundfont, core)
                        for _ in range(3)), key=lambda x: x[1])
    fs_s = len(read_mono(tmp / "speed_fs.wav")) / RATE  # its file runs on past the last note
    print(f"| FluidSynth {_fs_version()}, whole run (best of 3) | {wall:.2f} | {fs_cpu:.2f} | "
          f"{audio_s / wall:.1f} | {audio_s / fs_cpu:.1f} |")
    synth = max(fs_cpu - startup[1], 1e-6)
    print(f"| FluidSynth, less its start-up ({startup[1]:.2f} s CPU) | | {synth:.3f} | | "
          f"{audio_s / synth:.0f} |")
    ratio = cpu / fs_cpu
    print(f"\nguitar-synth takes {ratio:.0f}x the CPU time of FluidSynth's whole run on this "
          f"score ({'slower' if ratio > 1 else 'faster'}); FluidSynth's file is {fs_s:.1f} s "
          "long (its release tails run past the last note).\n")


def _fs_version() -> str:
    out = subprocess.run(["fluidsynth", "--version"], capture_output=True, text=True).stdout
    first = out.splitlines()[0] if out else ""
    return first.split()[-1] if first else ""


# ---- accuracy -------------------------------------------------------------------------------


@dataclass
class Tracked:
    times: np.ndarray
    midi: np.ndarray  # NaN where unvoiced
    onsets: np.ndarray


def track(y: np.ndarray, fmin: float, fmax: float) -> Tracked:
    import librosa

    hop = 256
    f0, voiced, _ = librosa.pyin(y, fmin=fmin, fmax=fmax, sr=RATE, frame_length=4096,
                                 hop_length=hop)
    times = librosa.times_like(f0, sr=RATE, hop_length=hop)
    midi = np.where(voiced, librosa.hz_to_midi(np.where(voiced, f0, 1.0)), np.nan)
    onsets = librosa.onset.onset_detect(y=y, sr=RATE, hop_length=hop, units="time",
                                        backtrack=False)
    return Tracked(times, midi, onsets)


def transcribe(t: Tracked, min_frames: int = 8) -> tuple[np.ndarray, np.ndarray]:
    """Notes from the tracked pitch: runs of at least ``min_frames`` voiced frames (46 ms) on one
    semitone, split where an onset was detected; each starts at the detected onset just before it
    (within 50 ms) if any."""
    semis = np.where(np.isnan(t.midi), -1, np.round(np.nan_to_num(t.midi, nan=-1))).astype(int)
    onset_frames = set(np.searchsorted(t.times, t.onsets).tolist())
    notes: list[tuple[int, int, int]] = []
    start = None
    for i in range(len(semis) + 1):
        cur = semis[i] if i < len(semis) else -1
        boundary = (i == len(semis) or start is None or cur != semis[start]
                    or i in onset_frames)
        if boundary:
            if start is not None and semis[start] >= 0 and i - start >= min_frames:
                notes.append((start, i, semis[start]))
            start = i if cur >= 0 else None
    intervals, pitches = [], []
    for a, b, _ in notes:
        t0 = t.times[a]
        before = t.onsets[(t.onsets <= t0 + 1e-9) & (t.onsets >= t0 - 0.05)]
        t0 = float(before[-1]) if len(before) else float(t0)
        intervals.append((t0, max(float(t.times[b - 1]), t0 + 0.01)))
        pitches.append(float(np.median(t.midi[a:b])))
    return np.array(intervals).reshape(-1, 2), np.array(pitches)


def held_pitch_errors(y: np.ndarray, notes: list[Note], fmin: float, fmax: float
                      ) -> list[tuple[Note, float]]:
    """(note, deviation in cents) of each plainly played label held at least ``HELD_S``: the
    median YIN pitch from ``SETTLE_S`` after the attack, over at most ``MEASURE_S``."""
    import librosa

    out = []
    for n in notes:
        if n.end - n.start < HELD_S or not plain(n):
            continue
        a = int((n.start + SETTLE_S) * RATE)
        b = int(min(n.start + SETTLE_S + MEASURE_S, n.end - 0.01) * RATE)
        seg = y[a:b]
        if len(seg) < 4096:
            continue
        f0 = librosa.yin(seg, fmin=fmin, fmax=fmax, sr=RATE, frame_length=4096, hop_length=512,
                         center=False)
        cents = 100 * (librosa.hz_to_midi(float(np.median(f0))) - n.pitch)
        out.append((n, float(cents)))
    return out


def accuracy(path: Path, quality: str, soundfont: str | None, core: int, tmp: Path) -> None:
    import librosa
    import mir_eval

    scene = score.score_to_scene(path, all_instruments=True)
    scene["quality"] = quality
    notes = label_notes(score.scene_labels(scene))
    lo, hi = min(n.pitch for n in notes), max(n.pitch for n in notes)
    fmin, fmax = librosa.midi_to_hz(lo - 3), librosa.midi_to_hz(hi + 3)
    t0 = time.perf_counter()
    ours = engine.render_result(scene)
    render_s = time.perf_counter() - t0
    y_ours = np.asarray(ours.audio, dtype=np.float64)
    y_ours = y_ours.mean(axis=1) if y_ours.ndim == 2 else y_ours
    rows = [("guitar-synth", y_ours)]
    if soundfont is not None:
        write_midi(notes, [t["guitar"]["preset"] for t in scene["tracks"]], tmp / "acc.mid")
        fluidsynth(tmp / "acc.mid", tmp / "acc_fs.wav", soundfont, core)
        rows.append(("FluidSynth", read_mono(tmp / "acc_fs.wav")))
    ref_int = np.array([(n.start, n.end) for n in notes])
    ref_hz = librosa.midi_to_hz(np.array([n.pitch for n in notes]))
    print(f"## Accuracy: {path.name} ({len(scene['tracks'])} track, {len(notes)} notes, "
          f"{scene['duration']:.1f} s; rendered at quality {quality} in {render_s:.1f} s)\n")
    print("| audio | notes found | onset P | onset R | onset F1 | held notes measured | "
          "within ±10 c | median abs c | worst c |")
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: | ---: | ---: |")
    worst_rows = []
    for name, y in rows:
        tr = track(y, fmin, fmax)
        est_int, est_midi = transcribe(tr)
        p, r, f, _ = mir_eval.transcription.precision_recall_f1_overlap(
            ref_int, ref_hz, est_int, librosa.midi_to_hz(est_midi) if len(est_midi)
            else np.zeros(0), onset_tolerance=0.05, pitch_tolerance=50.0, offset_ratio=None)
        errs = held_pitch_errors(y, notes, fmin, fmax)
        dev = np.array([c for _, c in errs])
        within = int(np.sum(np.abs(dev) <= 10.0))
        worst = max(errs, key=lambda e: abs(e[1])) if errs else None
        med = f"{np.median(np.abs(dev)):.1f}" if len(dev) else "-"
        print(f"| {name} | {len(est_midi)} | {p:.3f} | {r:.3f} | {f:.3f} | {len(errs)} | "
              f"{within} | {med} | {f'{worst[1]:+.1f}' if worst else '-'} |")
        if name == "guitar-synth":
            worst_rows = sorted(errs, key=lambda e: -abs(e[1]))
            missed = _missed(ref_int, ref_hz, est_int, est_midi)
    print()
    bad = [(n, c) for n, c in worst_rows if abs(c) > 10.0]
    if bad:
        print(f"guitar-synth's labels off by more than 10 cents ({len(bad)}):")
        for n, c in bad[:8]:
            print(f"  {n.start:7.3f} s  {librosa.midi_to_note(round(n.pitch))} "
                  f"(MIDI {n.pitch:.2f}, string {n.string} fret {n.fret}, held "
                  f"{n.end - n.start:.2f} s): {c:+.1f} cents")
    if missed:
        print(f"labels the tracker did not find in guitar-synth's audio ({len(missed)}; the "
              "first 8):")
        for t, m in missed[:8]:
            print(f"  {t:7.3f} s  {librosa.midi_to_note(round(m))}")
    print()


def _missed(ref_int, ref_hz, est_int, est_midi) -> list[tuple[float, float]]:
    import librosa
    import mir_eval

    est_hz = librosa.midi_to_hz(est_midi) if len(est_midi) else np.zeros(0)
    matched = mir_eval.transcription.match_notes(ref_int, ref_hz, est_int, est_hz,
                                                 onset_tolerance=0.05, pitch_tolerance=50.0,
                                                 offset_ratio=None)
    hit = {i for i, _ in matched}
    midi = librosa.hz_to_midi(ref_hz)
    return [(float(ref_int[i, 0]), float(midi[i])) for i in range(len(ref_int)) if i not in hit]


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--speed", default=DEFAULT_SPEED, metavar="SCORE",
                    help=f"the score for the speed table (default {DEFAULT_SPEED}); 'none' skips")
    ap.add_argument("--accuracy", nargs="*", default=DEFAULT_ACCURACY, metavar="SCORE",
                    help="monophonic scores for the accuracy tables (default: "
                         f"{' '.join(DEFAULT_ACCURACY)})")
    ap.add_argument("--quality", default="standard", choices=("draft", "standard", "high"))
    args = ap.parse_args(argv)
    core = one_core()
    soundfont = next((s for s in SOUNDFONTS if Path(s).exists()), None)
    if shutil.which("fluidsynth") is None:
        soundfont = None
    t0 = time.perf_counter()
    engine.warmup()
    print(f"(engine.warmup: {time.perf_counter() - t0:.1f} s, not counted)\n")
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        if args.speed != "none":
            speed(corpus_file(args.speed), args.quality, soundfont, core, tmp)
        for name in args.accuracy:
            accuracy(corpus_file(name), args.quality, soundfont, core, tmp)


if __name__ == "__main__":
    main()
