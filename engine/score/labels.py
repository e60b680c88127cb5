"""Note labels of any scene, as a JAMS file in GuitarSet's layout.

The labels are read from the scene's events alone (hand-written scenes as well as converted
scores), with the rules below, so that they say what the scene plays, at the times it plays it.

Layout (as GuitarSet, Xi et al. 2018): one ``note_midi`` annotation per string of each track, in
track order and, within a track, from the lowest string to the highest; each annotation's
``annotation_metadata.data_source`` is the string's index counted from the lowest string
(``"0"`` = the lowest, as GuitarSet numbers its six strings).  Each observation is one note:
``time`` and ``duration`` in seconds as in the scene's events, ``value`` its (fractional) MIDI
pitch at the attack, ``confidence`` None.  What else belongs to a note is kept once, in the
annotation's **sandbox**: ``sandbox.notes`` is a list in the same order as the observations (sorted
by time, one note per string at a time), each ``{"fret", "attack", "articulations"}``; ``sandbox``
also holds ``track``, ``track_name``, ``string`` (1 = highest, as the scene numbers strings),
``open_pitch`` and ``unpitched`` (attacks of dead notes: no pitch sounds, so they are no
``note_midi`` observation).  After them, one ``pitch_contour`` annotation per string in the same
order: f0 in Hz at the frames ``k * contour_hop`` while a note sounds (value ``{"index": the
note's place in the string's note_midi data, "frequency", "voiced"}``, one unvoiced frame after
a note the string does not follow at once; ``_contour`` says how it is computed; the pitch glide
of hard plucks, which depends on the string's motion, is not in it).  A converted score adds
``beat`` and ``tempo`` annotations (and ``key_mode``, ``chord`` where the score has them) from
``scene["score"]``; ``sandbox.guitar_synth`` says what made the audio (``provenance``).  All of
it survives ``jams.load``.

Rules (one string at a time, its events in time order; at equal times a ``damp`` first, then the
left hand (``fret``, ``slide``, touches, palm, bends), then attacks):

* A note starts at every attack: a ``pluck``, each pluck of a ``strum`` (the engine's times: low to
  high for ``down``, the spread divided evenly), a ``tap``, a ``hammer_on`` at a fret at or above
  every fret held, a ``pull_off`` of the highest fret held, and the arrival of a ``slide`` that
  starts more than 5 ms after the note's attack, on a sounding string, with no attack within 1 ms
  and no damp within 10 ms of its arrival.  A slide that starts within 5 ms of an attack is a slide
  into that note: the note is labelled with the fret it arrives at.
* Its pitch: the open string (the tuning of the track's preset and overrides) plus the highest fret
  held at that moment, plus the bend in effect then.  With a ``harmonic`` touch on the string, the
  note is the k-th partial of the stopped string, k the smallest of 2..16 whose node (j/k of the
  length from the stopping fret to the bridge) lies within ``HARMONIC_TOLERANCE / k`` of the touch;
  a touch at no such node leaves no pitch (a dead note).
* It ends at the string's next note, at a ``damp`` of the string (or of all strings), or at the
  scene's end.  A finger lifted without an attack starts no note.
"""

from __future__ import annotations

import math
from dataclasses import replace
from types import SimpleNamespace

import numpy as np

from .. import presets as _presets
from ..performance import bend_points, finger_x_m, strum_times, vibrato_points
from .common import note_midi

HARMONIC_TOLERANCE = 0.02  # |k r - j| for the touch at r of the speaking length
SLIDE_IN_S = 0.005
ATTACKS = ("pluck", "tap", "hammer_on", "pull_off")
_ORDER = {"damp": 0, "fret": 1, "slide": 1, "harmonic": 1, "mute": 1, "bend": 1, "vibrato": 1,
          "pluck": 2, "tap": 2, "hammer_on": 2, "pull_off": 2, "arrival": 3}


def _tracks(scene: dict) -> list[dict]:
    if hasattr(scene, "model_dump"):
        scene = scene.model_dump(exclude_none=True)
    if scene.get("tracks"):
        return [dict(t) for t in scene["tracks"]]
    return [{"name": "guitar", "guitar": scene.get("guitar") or {},
             "events": scene.get("events") or []}]


class _Geometry:
    """A track's strings: open pitches, and the preset's geometry of each (its scale, with the
    string's saddle setback and nut compensation, overridden where the guitar says) that a touch
    is measured against."""

    def __init__(self, guitar: dict):
        preset = _presets.get_preset(guitar.get("preset", _presets.DEFAULT_PRESET))
        tuning = guitar.get("tuning")
        notes = list(tuning) if tuning else [s.note for s in preset.strings]
        specs = list(preset.strings)
        for o in guitar.get("strings") or []:
            i = o["string"] - 1
            if o.get("note") and i < len(notes):
                notes[i] = o["note"]
            if i < len(specs):
                specs[i] = replace(specs[i], **{
                    k: o[k] for k in ("saddle_setback_m", "nut_compensation_m")
                    if o.get(k) is not None})
        self.notes = notes
        self.open = [note_midi(n) for n in notes]
        self.preset = preset
        self.specs = specs + [specs[-1]] * max(len(notes) - len(specs), 0)
        self.n = len(notes)

    def length(self, string: int) -> float:
        return self.preset.speaking_length_m(self.specs[string - 1])

    def fret_x(self, fret: float, string: int) -> float:
        """Metres from the string's (compensated) nut."""
        return float(self.preset.fret_x_m(fret, self.specs[string - 1]))


def _expand(events: list[dict], n_strings: int, duration: float) -> dict[int, list[dict]]:
    per: dict[int, list[dict]] = {s: [] for s in range(1, n_strings + 1)}
    for i, e in enumerate(events):
        kind = e.get("type")
        if kind == "strum":
            for s, t in strum_times(e["time"], e.get("strings"), e.get("direction", "down"),
                                    e.get("spread", 0.03), n_strings):
                if t < duration and s in per:
                    per[s].append({"type": "pluck", "time": t, "string": s, "_seq": i,
                                   "_strum": e.get("direction", "down")})
        elif kind in ("mute", "damp") and e.get("string") is None:
            for s in per:
                per[s].append({**e, "string": s, "_seq": i})
        elif e.get("string") in per:
            per[e["string"]].append({**e, "_seq": i})
    return per


def _bend_at(bends: list[dict], t: float) -> float:
    best = 0.0
    for b in bends:
        on, up, semis = b["time"], max(b.get("duration", 0.15), 1e-9), b["semitones"]
        if t < on:
            continue
        v = semis * min((t - on) / up, 1.0)
        rel = b.get("release")
        if rel is not None and t >= rel:
            v = semis * max(1.0 - (t - rel) / up, 0.0)
        best = max(best, v)
    return best


def _string_notes(evs: list[dict], geo: _Geometry, string: int, duration: float):
    """(notes, unpitched) of one string."""
    evs = sorted(evs, key=lambda e: (e["time"], _ORDER.get(e["type"], 1), e["_seq"]))
    attacks = [e["time"] for e in evs if e["type"] in ATTACKS]
    damps = [e["time"] for e in evs if e["type"] == "damp"]
    slides = [e for e in evs if e["type"] == "slide"]
    slide_in = set()
    for sl in slides:
        if any(-SLIDE_IN_S <= sl["time"] - a <= SLIDE_IN_S for a in attacks):
            slide_in.add(id(sl))
    timeline = list(evs)
    for sl in slides:
        if id(sl) not in slide_in:
            timeline.append({"type": "arrival", "time": sl["time"] + sl.get("duration", 0.15),
                             "string": string, "_slide": sl, "_seq": sl["_seq"]})
    timeline.sort(key=lambda e: (e["time"], _ORDER.get(e["type"], 1), e["_seq"]))

    fingers: list[dict] = []  # {"fret", "on", "rel", "slide": (t0, t1, a, b) or None}
    touches: list[tuple[float, float, float]] = []  # (on, off, x_m)
    mutes: list[tuple[float, float]] = []
    bends: list[dict] = []
    notes: list[dict] = []
    unpitched: list[dict] = []
    cur: dict | None = None

    def held(t: float) -> list[dict]:
        return [f for f in fingers if f["on"] <= t < f["rel"]]

    def fret_of(f: dict, t: float) -> int:
        if f["slide"] is None:
            return f["fret"]
        t0, t1, a, b = f["slide"]
        return b if t >= t1 else a

    def top(t: float) -> int:
        return max((fret_of(f, t) for f in held(t)), default=0)

    def end_current(t: float):
        nonlocal cur
        if cur is not None:
            cur["duration"] = max(t - cur["time"], 0.0)
            (unpitched if cur.get("_dead") else notes).append(cur)
        cur = None

    def start(t: float, fret: int, attack: str, extra=()):
        nonlocal cur
        end_current(t)
        arts = [attack] + list(extra)
        into = [sl for sl in slides if id(sl) in slide_in and abs(sl["time"] - t) <= SLIDE_IN_S]
        if into:  # a slide into this note: labelled with the fret it arrives at
            fret = into[0]["to_fret"]
            arts.append("slide_in")
        pitch = geo.open[string - 1] + fret
        harmonic = 0.0
        bend = _bend_at(bends, t)
        if bend > 1e-6:
            pitch += bend
            arts.append("prebend")
        touch = next((x for (on, off, x) in touches if on <= t < off), None)
        dead = False
        if touch is not None:
            x_stop = geo.fret_x(fret, string) if fret > 0 else 0.0
            length = geo.length(string)
            r = (touch - x_stop) / (length - x_stop)
            if 0.0 < r < 1.0:
                k = next((k for k in range(2, 17)
                          if abs(k * r - round(k * r)) <= HARMONIC_TOLERANCE
                          and 1 <= round(k * r) <= k - 1), None)
                if k is None:
                    dead = True
                    arts.append("dead")
                else:
                    pitch += 12.0 * math.log2(k)
                    harmonic = 12.0 * math.log2(k)
                    arts.append(f"harmonic_{k}")
        if any(on <= t < off for (on, off) in mutes):
            arts.append("palm_mute")
        cur = {"time": t, "duration": 0.0, "pitch": round(pitch, 4), "string": string,
               "fret": fret, "attack": attack, "articulations": arts}
        if dead:
            cur["_dead"] = True
        cur["_harmonic"] = harmonic

    for e in timeline:
        t, kind = e["time"], e["type"]
        if t >= duration:
            break
        if kind == "damp":
            end_current(t)
        elif kind == "fret":
            for f in held(t):
                f["rel"] = t
            if e["fret"] > 0:
                fingers.append({"fret": e["fret"], "on": t, "rel": e.get("release") or math.inf,
                                "slide": None})
        elif kind == "slide":
            for f in held(t):
                f["rel"] = t
            d = e.get("duration", 0.15)
            fingers.append({"fret": e["to_fret"], "on": t, "rel": e.get("release") or math.inf,
                            "slide": (t, t + d, e["from_fret"], e["to_fret"])})
        elif kind == "harmonic":
            x = (geo.fret_x(e["fret"], string) if e.get("fret") is not None
                 else e["position"] * geo.length(string))
            touches.append((t, e.get("release") or math.inf, x))
        elif kind == "mute":
            mutes.append((t, e.get("release") or math.inf))
        elif kind == "bend":
            bends.append(e)
            if cur is not None:
                cur["articulations"].append("bend")
        elif kind == "vibrato":
            if cur is not None:
                cur["articulations"].append("vibrato")
        elif kind == "pluck":
            start(t, top(t), "strum_" + e["_strum"] if "_strum" in e else "pluck")
        elif kind == "tap":
            for f in held(t):
                f["rel"] = t
            fingers.append({"fret": e["fret"], "on": t, "rel": e.get("release") or math.inf,
                            "slide": None})
            start(t, e["fret"], "tap")
        elif kind == "hammer_on":
            before = top(t)
            fingers.append({"fret": e["fret"], "on": t, "rel": e.get("release") or math.inf,
                            "slide": None})
            if e["fret"] >= before:
                start(t, e["fret"], "hammer_on")
        elif kind == "pull_off":
            before = top(t)
            mine = [f for f in held(t) if fret_of(f, t) == e["fret"]]
            if mine:
                mine[-1]["rel"] = t
                if e["fret"] >= before:
                    start(t, top(t), "pull_off")
        elif kind == "arrival":
            sl = e["_slide"]
            if cur is None or cur.get("_dead") or sl["time"] - cur["time"] <= SLIDE_IN_S:
                continue
            if any(abs(a - t) <= 1e-3 for a in attacks):
                continue
            if any(-1e-3 <= d - t <= 0.010 for d in damps):
                continue
            rel = sl.get("release")
            if rel is not None and rel <= t + 1e-3:
                continue
            start(t, sl["to_fret"], "slide")
    end_current(duration)
    return notes, unpitched, fingers


def scene_notes(scene) -> list[dict]:
    """Every labelled note of a scene (all tracks and strings), sorted by time: dicts with
    ``time``, ``duration``, ``pitch``, ``track``, ``track_name``, ``string``, ``fret``, ``attack``,
    ``articulations``."""
    out = []
    for per in _labels(scene):
        out.extend(per["notes"])
    return sorted(out, key=lambda n: (n["time"], n["track"], n["string"]))


def _labels(scene, hop: float | None = None) -> list[dict]:
    """Per string of each track (lowest first): its notes and unpitched attacks, and with a
    ``hop`` (s) its pitch contour (``_contour``)."""
    if hasattr(scene, "model_dump"):
        scene = scene.model_dump(exclude_none=True)
    duration = float(scene["duration"])
    rate = int(scene.get("sample_rate", 44100))
    result = []
    for ti, tr in enumerate(_tracks(scene)):
        geo = _Geometry(tr.get("guitar") or {})
        name = tr.get("name") or f"track {ti + 1}"
        model = tr.get("model") or scene.get("model") or "fdtd"
        per = _expand(tr.get("events") or [], geo.n, duration)
        for s in range(geo.n, 0, -1):  # lowest string first, as GuitarSet
            notes, unpitched, fingers = _string_notes(per[s], geo, s, duration)
            harmonics = [n.pop("_harmonic", 0.0) for n in notes]
            for n in notes + unpitched:
                n.pop("_dead", None)
                n.pop("_harmonic", None)
                n["track"], n["track_name"] = ti, name
                n["duration"] = round(n["duration"], 9)
            item = {"track": ti, "track_name": name, "string": s, "index": geo.n - s,
                    "open_pitch": round(geo.open[s - 1], 4), "notes": notes,
                    "unpitched": unpitched}
            if hop:
                item["contour"] = _contour(notes, harmonics, fingers, per[s], geo, s, rate,
                                           model, hop)
            result.append(item)
    return result


def _stop(fingers: list[dict], geo: _Geometry, string: int, t: float) -> float:
    """The fret stopping the string at ``t``: the highest of the fingers down; a sliding finger
    stops it at the first fret wire beyond it (its pitch steps fret by fret, as in both
    models)."""
    best = 0
    for f in fingers:
        if not f["on"] <= t < f["rel"]:
            continue
        if f["slide"] is None:
            best = max(best, f["fret"])
            continue
        t0, t1, a, b = f["slide"]
        if t >= t1 or t1 <= t0:
            best = max(best, b)
            continue
        spec = geo.specs[string - 1]
        xa, xb = (finger_x_m(geo.preset, q, spec) for q in (a, b))
        x = xa + (xb - xa) * max(t - t0, 0.0) / (t1 - t0)
        q = next((q for q in range(1, geo.preset.frets + 1)
                  if float(geo.preset.fret_x_m(q, spec)) > x), geo.preset.frets)
        best = max(best, q)
    return best


# what each string model interpolates between a bend's breakpoints: the tension (True: the
# finite-difference string, whose pitch goes with its square root) or the pitch ratio itself
BEND_ON_TENSION = {"fdtd": True, "waveguide": False}


def _ratio_curve(evs: list[dict], rate: int, model: str):
    """(times, pitch ratios) of the string's bends and vibratos, linear between them as each
    model plays them: the breakpoints of ``performance.bend_points``/``vibrato_points`` at
    the scene's sample rate, merged (a later one at the same step wins); the waveguide
    interpolates the pitch ratio, the finite-difference string the tension, i.e. its square."""
    points: list[tuple[int, float]] = []

    def step(t: float) -> int:
        return int(round(t * rate))

    def cents(c: float) -> float:
        return 2.0 ** (c / 1200.0)

    for e in evs:
        if e["type"] == "bend":
            b = SimpleNamespace(time=e["time"], duration=e.get("duration", 0.15),
                                release=e.get("release"), semitones=e["semitones"])
            pts, _ = bend_points(b, step(b.time), step, cents(100.0 * b.semitones))
            points += pts
        elif e["type"] == "vibrato":
            v = SimpleNamespace(time=e["time"], duration=e.get("duration", 1.0),
                                rate_hz=e.get("rate_hz", 5.5), depth_cents=e.get("depth_cents", 20.0))
            pts, _ = vibrato_points(v, step, cents)
            points += pts
    points.sort(key=lambda p: p[0])
    if not points or points[0][0] > 0:
        points.insert(0, (0, 1.0))
    steps: list[int] = []
    ratios: list[float] = []
    for st, r in points:
        if steps and steps[-1] == st:
            ratios[-1] = r
        else:
            steps.append(st)
            ratios.append(r)
    times = np.asarray(steps, float) / rate
    r = np.asarray(ratios)
    return times, (r * r if BEND_ON_TENSION[model] else r)


def _contour(notes, harmonics, fingers, evs, geo: _Geometry, string: int, rate: int, model: str,
             hop: float) -> dict:
    """f0 of one string while each of its notes sounds, at the frames ``k * hop``: the open
    string, the fret stopping it (slides step through the frets), the note's harmonic, bends
    and vibrato; parallel lists ``time``, ``frequency`` (Hz), ``index`` (the note's place in
    the string's ``note_midi`` data) and ``voiced`` (False on the frame after a note ends
    where no note sounds)."""
    bt, br = _ratio_curve(evs, rate, model)
    out: dict = {"time": [], "frequency": [], "index": [], "voiced": []}
    open_pitch = geo.open[string - 1]
    ons = np.array([f["on"] for f in fingers], float)
    rels = np.array([f["rel"] for f in fingers], float)
    for i, n in enumerate(notes):
        start, end = n["time"], n["time"] + n["duration"]
        k0, k1 = math.ceil(start / hop - 1e-9), math.ceil(end / hop - 1e-9)
        if k1 <= k0:
            continue
        times = np.arange(k0, k1) * hop
        ratio = np.interp(times, bt, br)
        if BEND_ON_TENSION[model]:
            ratio = np.sqrt(ratio)
        stops = np.zeros(len(times))
        for j in np.nonzero((ons < end) & (rels > start))[0]:
            fg = fingers[j]
            down = (times >= fg["on"]) & (times < fg["rel"])
            q = np.full(len(times), float(fg["fret"]))
            if fg["slide"] is not None:  # fret by fret while it moves
                q[:] = fg["slide"][3]
                for j in np.nonzero(down & (times < fg["slide"][1]))[0]:
                    q[j] = _stop([fg], geo, string, float(times[j]))
            stops = np.maximum(stops, np.where(down, q, 0.0))
        f = 440.0 * 2.0 ** ((open_pitch + harmonics[i] + stops - 69.0) / 12.0) * ratio
        out["time"] += [round(float(t), 6) for t in times]
        out["frequency"] += [round(float(x), 3) for x in f]
        out["index"] += [i] * len(times)
        out["voiced"] += [True] * len(times)
        nxt = notes[i + 1]["time"] if i + 1 < len(notes) else math.inf
        if k1 * hop < nxt - 1e-9:  # the note is over and the string silent: one unvoiced frame
            out["time"].append(round(k1 * hop, 6))
            out["frequency"].append(out["frequency"][-1])
            out["index"].append(i)
            out["voiced"].append(False)
    return out


CONTOUR_HOP_S = 0.01  # frames of the pitch contours
TOOL = "guitar-synth engine.score.labels"


def scene_labels(scene, title: str = "", contour_hop: float | None = CONTOUR_HOP_S,
                 metadata: dict | None = None):
    """The scene's labels as a ``jams.JAMS`` (see the module's docstring for the layout).
    ``title``: the file's title where the score gives none (a scene has none); ``contour_hop``:
    the pitch contours' frame hop in seconds (None: no contours); ``metadata``: more of the
    file's provenance for ``sandbox.guitar_synth`` (a dataset item's ``seed`` ...)."""
    import jams

    if hasattr(scene, "model_dump"):
        scene = scene.model_dump(exclude_none=True)
    duration = float(scene["duration"])
    info = scene.get("score") or {}
    jam = jams.JAMS()
    jam.file_metadata.duration = duration
    jam.file_metadata.title = info.get("title") or title
    jam.file_metadata.artist = info.get("artist") or ""
    jam.sandbox.update(guitar_synth=provenance(scene, metadata))
    strings = _labels(scene, contour_hop)
    for per in strings:
        ann = jams.Annotation(namespace="note_midi", time=0.0, duration=duration)
        ann.annotation_metadata.data_source = str(per["index"])
        ann.annotation_metadata.annotation_tools = TOOL
        for n in per["notes"]:
            ann.append(time=float(n["time"]), duration=float(n["duration"]),
                       value=float(n["pitch"]), confidence=None)
        ann.sandbox.update(
            track=per["track"], track_name=per["track_name"], string=per["string"],
            open_pitch=per["open_pitch"],
            notes=[{"fret": n["fret"], "attack": n["attack"], "articulations": n["articulations"]}
                   for n in per["notes"]],
            unpitched=[{k: n[k] for k in ("time", "duration", "fret", "attack", "articulations")}
                       for n in per["unpitched"]])
        jam.annotations.append(ann)
    for per in strings if contour_hop else ():
        c = per["contour"]
        ann = jams.Annotation(namespace="pitch_contour", time=0.0, duration=duration)
        ann.annotation_metadata.data_source = str(per["index"])
        ann.annotation_metadata.annotation_tools = TOOL
        for t, f, i, v in zip(c["time"], c["frequency"], c["index"], c["voiced"], strict=True):
            ann.append(time=t, duration=0.0, value={"index": i, "frequency": f, "voiced": v},
                       confidence=None)
        ann.sandbox.update(track=per["track"], track_name=per["track_name"],
                           string=per["string"], hop=contour_hop)
        jam.annotations.append(ann)
    _score_annotations(jam, info, duration)
    return jam


def save_labels(jam, target) -> None:
    """Write ``jam`` as compact JSON (``jams.load`` reads it) to a path or a text file: a
    song's contours are tens of thousands of frames, which ``JAMS.save``'s indented JSON makes
    two and a half times larger."""
    import json

    text = json.dumps(jam.__json__, separators=(",", ":"), allow_nan=False)
    if hasattr(target, "write"):
        target.write(text)
    else:
        with open(target, "w", encoding="utf-8") as f:
            f.write(text)


def summary(scene) -> dict:
    """A scene's labelled notes in brief, for a dataset's manifest: ``notes`` (how many) and
    ``articulations`` (the names used, sorted)."""
    notes = scene_notes(scene)
    return {"notes": len(notes),
            "articulations": sorted({a for n in notes for a in n["articulations"]})}


def provenance(scene: dict, metadata: dict | None = None) -> dict:
    """What made the labels' audio: the project's version, the scene's model, quality and
    sample rate, each track's name, preset, tuning and model, and the score it came from (its
    file name and format), with ``metadata`` added (a dataset item's seed ...)."""
    from importlib import metadata as im

    try:
        version = im.version("guitar-synth")
    except im.PackageNotFoundError:
        version = "unknown"
    info = scene.get("score") or {}
    tracks = []
    for tr in _tracks(scene):
        g = tr.get("guitar") or {}
        geo = _Geometry(g)
        tracks.append({"name": tr.get("name") or "", "preset": geo.preset.name,
                       "tuning": list(geo.notes),
                       "model": tr.get("model") or scene.get("model") or "fdtd"})
    out = {"version": version, "model": scene.get("model") or "fdtd",
           "quality": scene.get("quality") or "standard",
           "sample_rate": int(scene.get("sample_rate", 44100)), "tracks": tracks,
           "source": info.get("source") or "", "format": info.get("format") or "scene"}
    out.update(metadata or {})
    return out


def _score_annotations(jam, info: dict | None, duration: float) -> None:
    """``beat`` (value: the beat's place in its bar, 1 = downbeat, as GuitarSet), ``tempo``
    (quarter notes per minute over each stretch of constant tempo, confidence 1), ``key_mode``
    and ``chord`` (each until the next) of a converted score (``engine.scene.ScoreInfo``);
    nothing for a scene written by hand."""
    import jams

    if not info:
        return
    tool = "guitar-synth engine.score.labels"
    beats = [(t, p) for t, p in zip(info.get("beats") or [], info.get("beat_positions") or [],
                                     strict=False) if t < duration]
    if beats:
        ann = jams.Annotation(namespace="beat", time=0.0, duration=duration)
        ann.annotation_metadata.annotation_tools = tool
        ann.annotation_metadata.data_source = "score"
        for t, p in beats:
            ann.append(time=float(t), duration=0.0, value=int(p), confidence=None)
        jam.annotations.append(ann)
    for namespace, key, field, confidence in (("tempo", "tempo", "bpm", 1.0),
                                              ("key_mode", "keys", "value", None),
                                              ("chord", "chords", "value", None)):
        marks = [m for m in info.get(key) or [] if m["time"] < duration]
        if not marks:
            continue
        ann = jams.Annotation(namespace=namespace, time=0.0, duration=duration)
        ann.annotation_metadata.annotation_tools = tool
        ann.annotation_metadata.data_source = "score"
        for k, m in enumerate(marks):  # each lasts until the next
            end = marks[k + 1]["time"] if k + 1 < len(marks) else duration
            ann.append(time=float(m["time"]), duration=max(float(end - m["time"]), 0.0),
                       value=m[field], confidence=confidence)
        jam.annotations.append(ann)
