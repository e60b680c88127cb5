"""guitar-synth batch: many renders at once, on Dask, with a manifest; resumable.

    guitar-synth batch songs/ extra.gp5 -o out/
    guitar-synth batch dataset.yaml -o out/ --workers 8
    guitar-synth batch dataset.yaml -o out/ --scheduler tcp://10.0.0.5:8786

INPUTS are scene ``.json`` files, Guitar Pro ``.gp3``-``.gp5``, ``.gpx``, ``.gp`` and MIDI files,
folders (searched recursively for those), and dataset specs (``cli.dataset``: YAML, or JSON with a
top-level ``dataset``), each of which stands for ``count`` drawn scenes.  OUT_DIR receives
``audio/ID.wav`` (or ``.flac``), ``labels/ID.jams``, with ``--stems`` ``stems/ID/`` (each string's
file and ``stems.json``, as ``render --stems``: ``cli.stems``) and ``manifest.parquet`` (or ``.csv``):
one row per item with its input, seed, outputs, audio seconds, render seconds, energy error, status
and error.

Each item is one Dask task that renders a whole scene or song (``render_item``).  A task writes its
files as ``NAME.part`` and renames them into place, then returns its manifest row; only the client
writes the manifest (atomically, every few seconds and at the end).  So a worker that dies
mid-item leaves no file counted as done; the scheduler runs the task again on another worker, and
the manifest has exactly one row per item.  Run again, the command skips every item whose row says
``done`` with the same input hash and whose files exist, and redoes the rest.

Items are whole songs, not sections: ``benchmarks/batch.py`` measured Dask's cost per item at about
10 ms, under 1 % of even an 8 s scene's render, and a corpus has far more songs than a cluster has
workers; the longest items are submitted first so that no long song starts last.

Exit status: 0 when every item is done, 1 when some failed (their reasons are in the manifest),
2 for bad arguments, a bad spec or an output folder that cannot be written.
"""

from __future__ import annotations

import argparse
import csv
import hashlib
import itertools
import json
import os
import sys
import time
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from cli.common import EXIT_BAD_INPUT, SCENE_SUFFIXES, SCORE_SUFFIXES, BadInput, OneLineParser

SPEC_SUFFIXES = (".yaml", ".yml")
MANIFEST_INTERVAL_S = 5.0
COLUMNS = ("id", "input", "seed", "input_hash", "audio", "labels", "audio_seconds",
           "render_seconds", "energy_error", "status", "error", "warnings", "content", "preset",
           "model", "quality", "tuning", "duration", "notes", "articulations", "files", "stems")
LIST_COLUMNS = ("articulations", "files")  # lists in parquet; joined by ";" in CSV
CONTENT = {"scene": "scene", "score": "score", "drawn": "dataset"}


@dataclass
class Item:
    id: str
    input: str
    kind: str  # scene | score | drawn
    data: bytes | None = None  # file contents (scene or score)
    scene: dict | None = None  # a drawn scene (or None: drawn from ``spec`` when rendered)
    spec: Any = None  # a dataset.Spec whose scene ``index`` this item is, drawn on the worker
    index: int = 0
    seed: int | None = None
    error: str | None = None  # the input could not be read: fails without rendering
    duration: float = 0.0  # a guess at the cost, for the order of submission
    input_hash: str = ""
    options: dict = field(default_factory=dict)


# ---- the work of one item (runs on a Dask worker) ---------------------------------------------

_WARM = False


def _warm() -> None:
    """Load (or compile) every numba kernel once per worker process, before the first item's
    clock starts; then freeze what the process holds out of the garbage collector's sight, as the
    service's workers do after their warm-up: each full collection an item's allocations trigger
    would walk numba's objects again (``python -m benchmarks.gc_pause``)."""
    global _WARM
    if not _WARM:
        import gc

        import engine

        engine.warmup()
        gc.freeze()
        _WARM = True


def _score_scene(data: bytes, options: dict) -> tuple[dict, list[str]]:
    from engine import score

    if hasattr(score, "load_score"):
        r = score.load_score(data, **options)
        return dict(r.scene), list(r.warnings)
    r = score.score_to_scene(data, **options)
    return dict(r), list(getattr(r, "warnings", []))


def _labels(scene: Any, metadata: dict):
    from engine import score

    return score.scene_labels(scene, metadata=metadata)


def describe(sc: Any) -> dict[str, Any]:
    """The manifest's columns that say what an item is, to filter a dataset by: its presets
    (joined by "+" over tracks), string model(s), quality, tuning (each track's strings from the
    lowest, tracks joined by " | "), duration, notes and the articulations they use."""
    from engine import score

    tracks = sc.instruments()
    presets, models, tunings = [], [], []
    for t in tracks:
        p = t.preset()
        presets.append(t.guitar.preset)
        models.append(t.model or sc.model)
        tunings.append(" ".join(s.note for s in reversed(p.strings)))
    brief = score.label_summary(sc)
    return {"preset": "+".join(dict.fromkeys(presets)), "model": "+".join(dict.fromkeys(models)),
            "quality": sc.quality, "tuning": " | ".join(tunings), "duration": sc.duration,
            "notes": brief["notes"], "articulations": brief["articulations"]}


def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}"[:500]


def _replace_into(tmp: Path, final: Path) -> None:
    with open(tmp, "rb") as f:
        os.fsync(f.fileno())
    os.replace(tmp, final)


def render_item(item: Item, out_dir: str, options: dict) -> dict[str, Any]:
    """Render one item to OUT/audio and OUT/labels; its manifest row.  Idempotent: run twice
    (a retry after a worker died), it writes the same bytes to the same names."""
    _warm()
    import numpy as np
    import soundfile as sf
    from pydantic import ValidationError

    import engine

    out = Path(out_dir)
    row: dict[str, Any] = {"id": item.id, "input": item.input, "seed": item.seed,
                           "input_hash": item.input_hash, "status": "failed", "warnings": 0,
                           "content": CONTENT.get(item.kind, item.kind), "files": []}
    if item.error:
        row["error"] = item.error
        return row
    fmt = options.get("format") or "wav"
    audio_path = out / "audio" / f"{item.id}.{fmt}"
    labels_path = out / "labels" / f"{item.id}.jams"
    tmp_audio = audio_path.with_name(audio_path.name + ".part")
    tmp_labels = labels_path.with_name(labels_path.name + ".part")
    stems = None
    try:
        warnings: list[str] = []
        if item.kind == "score":
            scene, warnings = _score_scene(item.data or b"", options.get("score_options", {}))
        elif item.kind == "scene":
            scene = json.loads(item.data or b"")
            if not isinstance(scene, dict):
                raise ValueError("a scene is a JSON object")
        elif item.scene is None and item.spec is not None:
            from cli import dataset

            scene = dataset.draw_scene(item.spec, item.index)
        else:
            scene = dict(item.scene or {})
        if options.get("quality"):
            scene["quality"] = options["quality"]
        if options.get("model"):
            from cli.common import set_model

            set_model(scene, options["model"])
        if options.get("diagnostics"):
            scene["diagnostics"] = True
        max_s = options.get("max_seconds")
        if max_s and scene.get("duration", 0) > max_s:
            engine.truncate(scene, max_s)
        sc = engine.parse_scene(scene)
        if options.get("stems"):
            from cli.stems import StemWriter

            # written as they come (at the fixed gain) or spilled until the gain is known
            stems = StemWriter(out / "stems" / item.id, sc.sample_rate, fmt, sc.output.subtype,
                               None if sc.output.normalize else engine.FIXED_GAIN)
            stems.start(sc.stems())
        t0 = time.perf_counter()
        result = engine.render_result(sc, on_stems=None if stems is None else stems.write)
        seconds = time.perf_counter() - t0
        x = np.asarray(result.audio)
        if not np.all(np.isfinite(x)):
            raise FloatingPointError("the audio holds non-finite samples")
        subtype = sc.output.subtype if fmt == "wav" else (
            "PCM_16" if sc.output.subtype == "PCM_16" else "PCM_24")
        sf.write(tmp_audio, np.clip(x, -1.0, 1.0), sc.sample_rate, format=fmt.upper(),
                 subtype=subtype)
        row.update(describe(sc))
        if options.get("labels", True):
            from engine import score

            meta = {"id": item.id, "input": item.input, "seed": item.seed}
            with open(tmp_labels, "w", encoding="utf-8") as f:
                score.save_labels(_labels(sc, meta), f)
            _replace_into(tmp_labels, labels_path)
            row["labels"] = str(labels_path.relative_to(out))
            row["files"].append(row["labels"])
        if stems is not None:
            stems.close(result.gain)
            row["stems"] = str(stems.folder.relative_to(out))
            row["files"].append(f"{row['stems']}/stems.json")
            stems = None
        _replace_into(tmp_audio, audio_path)
        row["files"].insert(0, str(audio_path.relative_to(out)))
        row.update(status="done", audio=str(audio_path.relative_to(out)),
                   audio_seconds=len(x) / sc.sample_rate, render_seconds=seconds,
                   energy_error=result.energy_error,
                   warnings=len(warnings) + len(result.warnings or []))
    except ValidationError as exc:
        e = exc.errors()[0]
        loc = ".".join(str(p) for p in e.get("loc", ()))
        row["error"] = f"invalid scene: {loc}: {e.get('msg', '')}"[:500]
    except Exception as exc:  # recorded in the manifest; the batch goes on
        row["error"] = _one_line(exc)
    finally:
        if stems is not None:  # the render failed: no stems half written
            stems.abort()
        for tmp in (tmp_audio, tmp_labels):
            try:
                tmp.unlink()
            except OSError:
                pass
    return row


# ---- gathering items ---------------------------------------------------------------------------


def _hash(*parts: bytes) -> str:
    h = hashlib.sha256()
    for p in parts:
        h.update(p)
        h.update(b"\0")
    return h.hexdigest()[:16]


def _safe_id(text: str) -> str:
    keep = "".join(c if c.isalnum() or c in "-_." else "_" for c in text)
    return keep.strip("._") or "item"


@dataclass
class Plan:
    """What a batch renders: the files' items (a list) and the specs' items, drawn lazily: a
    spec of ten million scenes costs nothing until its items are rendered, one at a time."""

    files: list[Item]
    specs: list[tuple[Any, Path, bytes]]  # (dataset.Spec, its path, its bytes)
    opts_hash: bytes = b""

    @property
    def total(self) -> int:
        return len(self.files) + sum(spec.count for spec, _, _ in self.specs)

    def items(self) -> Iterator[Item]:
        """Every item: the files' longest first, then each spec's in index order (its scenes
        are drawn on the workers, from the spec and the index)."""
        yield from sorted(self.files, key=lambda i: -i.duration)
        for spec, path, spec_bytes in self.specs:
            low, high = spec.duration
            for i in range(spec.count):
                yield Item(id=_drawn_id(spec.name, i), input=f"{path}#{i}", kind="drawn",
                           spec=spec, index=i, seed=spec.seed, duration=(low + high) / 2,
                           input_hash=_hash(spec_bytes, str(i).encode(), self.opts_hash))


def _drawn_id(name: str, index: int) -> str:
    return f"{name}-{index:06d}"


def gather(inputs: list[str], options: dict) -> Plan:
    """The batch's items.  Ids are unique by construction: two files of one name get ``NAME``,
    ``NAME-2``, ``NAME-3``, ... (skipping every id another input has); two specs of one name, or
    a file whose id is one a spec draws, are refused naming both."""
    from cli import dataset

    items: list[Item] = []
    specs: list[tuple[Any, Path, bytes]] = []
    opts_hash = json.dumps({**{k: options.get(k) for k in (
        "quality", "diagnostics", "max_seconds", "format", "labels", "score_options")},
        # only when given: the items of a batch run before there was --model keep their ids
        **({"model": options["model"]} if options.get("model") else {}),
        **({"stems": True} if options.get("stems") else {})},
        sort_keys=True).encode()
    for text in inputs:
        p = Path(text)
        if not p.exists():
            raise BadInput(f"{text}: no such file or folder")
        if p.is_dir():
            files = sorted(f for f in p.rglob("*") if f.is_file() and f.suffix.lower() in (
                *SCENE_SUFFIXES, *SCORE_SUFFIXES) and not dataset.is_spec(f))
            names = [(f, f.relative_to(p).with_suffix("").as_posix().replace("/", "__"))
                     for f in files]
        elif dataset.is_spec(p):
            try:
                spec = dataset.load_spec(p)
            except dataset.SpecError as exc:
                raise BadInput(str(exc)) from None
            same = [q for other, q, _ in specs if other.name == spec.name]
            if same:
                raise BadInput(f"{p} and {same[0]}: two dataset specs named {spec.name!r} would "
                               f"draw the same ids ({_drawn_id(spec.name, 0)}, ...): give each "
                               "spec its own name")
            # the spec's bytes, and only them: an item's hash stays what it was in earlier runs
            specs.append((spec, p, p.read_bytes()))
            continue
        elif p.suffix.lower() in (*SCENE_SUFFIXES, *SCORE_SUFFIXES):
            names = [(p, p.stem)]
        else:
            raise BadInput(f"{text}: unknown input type {p.suffix or '(no suffix)'!r}: give "
                           "scene .json, Guitar Pro, MusicXML, MIDI or dataset spec (.yaml) files or "
                           "folders")
        for f, name in names:
            kind = "scene" if f.suffix.lower() in SCENE_SUFFIXES else "score"
            item = Item(id=_safe_id(name), input=str(f), kind=kind)
            try:
                item.data = f.read_bytes()
                item.input_hash = _hash(item.data, opts_hash)
                item.duration = _guess_duration(item)
            except OSError as exc:
                item.error = f"cannot read {f}: {exc.strerror or exc}"
                item.input_hash = _hash(b"unreadable", opts_hash)
            items.append(item)
    _unique_ids(items)
    for item in items:
        for spec, path, _ in specs:
            head, _, tail = item.id.rpartition("-")
            if head == spec.name and tail.isdigit() and len(tail) >= 6 \
                    and int(tail) < spec.count and _drawn_id(head, int(tail)) == item.id:
                raise BadInput(f"{item.input}: its id {item.id!r} is also item {int(tail)} of "
                               f"the spec {path}: rename the file or the spec")
    return Plan(items, specs, opts_hash)


def _unique_ids(items: list[Item]) -> None:
    """Files of one name get ``NAME``, ``NAME-2``, ... in the order given, never an id that any
    other input has by its own name (``a/x.json b/x.json x-2.json``: x, x-3, x-2)."""
    taken = {item.id for item in items}  # every input's own id, claimed first
    used: set[str] = set()
    for item in items:
        if item.id in used:
            n, base = 2, item.id
            while f"{base}-{n}" in taken or f"{base}-{n}" in used:
                n += 1
            item.id = f"{base}-{n}"
        used.add(item.id)


def _guess_duration(item: Item) -> float:
    if item.kind == "scene":
        try:
            return float(json.loads(item.data or b"{}").get("duration", 0.0))
        except (ValueError, AttributeError, TypeError):
            return 0.0
    return len(item.data or b"") / 1000.0  # a score's size stands in for its length


# ---- the manifest -------------------------------------------------------------------------------


def _manifest_path(out: Path, fmt: str) -> Path:
    return out / f"manifest.{fmt}"


def read_manifest(out: Path, fmt: str) -> dict[str, dict[str, Any]]:
    path = _manifest_path(out, fmt)
    if not path.exists():
        return {}
    try:
        if fmt == "parquet":
            import pyarrow.parquet as pq

            rows = pq.read_table(path).to_pylist()
        else:
            with open(path, newline="", encoding="utf-8") as f:
                rows = list(csv.DictReader(f))
    except Exception:
        return {}  # unreadable: every item is redone
    return {r["id"]: r for r in rows}


def write_manifest(out: Path, fmt: str, rows: list[dict[str, Any]]) -> None:
    path = _manifest_path(out, fmt)
    tmp = path.with_name(path.name + ".part")
    rows = sorted(rows, key=lambda r: r["id"])
    if fmt == "parquet":
        import pyarrow as pa
        import pyarrow.parquet as pq

        text, real, count = pa.string(), pa.float64(), pa.int64()
        types = {"seed": count, "audio_seconds": real, "render_seconds": real,
                 "energy_error": real, "warnings": count, "duration": real, "notes": count,
                 **{c: pa.list_(text) for c in LIST_COLUMNS}}
        schema = pa.schema([(c, types.get(c, text)) for c in COLUMNS])
        table = pa.Table.from_pylist([{c: _as_list(r.get(c)) if c in LIST_COLUMNS
                                       else r.get(c) for c in COLUMNS} for r in rows], schema)
        pq.write_table(table, tmp)
    else:
        with open(tmp, "w", newline="", encoding="utf-8") as f:
            w = csv.DictWriter(f, COLUMNS)
            w.writeheader()
            for r in rows:
                w.writerow({c: ";".join(_as_list(r.get(c))) if c in LIST_COLUMNS
                            else "" if r.get(c) is None else r.get(c) for c in COLUMNS})
    _replace_into(tmp, path)


def _as_list(v: Any) -> list[str]:
    """A list column's value: a list as it is, a CSV cell split at ";", nothing for None."""
    if v is None or v == "":
        return []
    return [str(x) for x in v] if isinstance(v, list | tuple) else str(v).split(";")


def _is_done(row: dict[str, Any] | None, item: Item, out: Path) -> bool:
    if not row or row.get("status") != "done" or row.get("input_hash") != item.input_hash:
        return False
    files = _as_list(row.get("files")) or (
        [row.get("audio")] + ([row.get("labels")] if row.get("labels") else []))
    return all(f and (out / f).is_file() and (out / f).stat().st_size > 0 for f in files)


# ---- the cluster --------------------------------------------------------------------------------


def _cores() -> int:
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


def connect(scheduler: str | None, workers: int | None):
    """A Dask client: of an existing scheduler, or of an embedded LocalCluster (one process of
    one thread per core)."""
    import logging

    from dask.distributed import Client, LocalCluster

    logging.getLogger("distributed").setLevel(logging.ERROR)
    if scheduler:
        try:
            return Client(scheduler, timeout="20s"), None
        except (OSError, TimeoutError) as exc:
            raise BadInput(f"--scheduler {scheduler}: cannot connect: {_one_line(exc)}") from None
    cluster = LocalCluster(n_workers=workers or _cores(), threads_per_worker=1, processes=True,
                           host="127.0.0.1", dashboard_address=None)
    return Client(cluster), cluster


# ---- the command ---------------------------------------------------------------------------------


def build_parser(prog: str = "guitar-synth batch") -> argparse.ArgumentParser:
    p = OneLineParser(prog=prog, description=__doc__.split("\n\n")[0])
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="scene .json, Guitar Pro, MusicXML, MIDI, dataset spec (.yaml) files or folders")
    p.add_argument("-o", "--output", required=True, metavar="OUT_DIR",
                   help="folder of audio/, labels/ and the manifest (created if missing)")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="an existing Dask scheduler (tcp://host:8786); default: a local cluster")
    p.add_argument("--workers", type=int, metavar="N",
                   help="worker processes of the local cluster (default: one per core)")
    p.add_argument("--format", choices=("wav", "flac"), default="wav", help="audio format")
    p.add_argument("--manifest", choices=("parquet", "csv"), default="parquet",
                   help="manifest format (default parquet)")
    p.add_argument("--quality", choices=("draft", "standard", "high"),
                   help="override every scene's quality")
    p.add_argument("--model", choices=("fdtd", "waveguide"),
                   help="override every scene's string model (every track's): fdtd, the "
                        "finite-difference string, or waveguide, the digital waveguide")
    p.add_argument("--max-seconds", type=float, metavar="S",
                   help="keep only the first S seconds of each item")
    p.add_argument("--diagnostics", action="store_true",
                   help="energy-balance figures in the manifest (slower renders)")
    p.add_argument("--no-labels", dest="labels", action="store_false", help="no JAMS labels")
    p.add_argument("--stems", action="store_true",
                   help="also each string's signal before body, pan, effects and mix: "
                        "stems/ID/t1-s6.wav ... and stems.json (the manifest's stems column)")
    p.add_argument("--retries", type=int, default=2, metavar="N",
                   help="extra tries of an item whose task raised (default 2); an item whose "
                        "worker died is retried by the scheduler as well")
    p.add_argument("-q", "--quiet", action="store_true", help="no progress bar or summary")
    return p


def _prepare_output(out: Path) -> None:
    try:
        for sub in ("", "audio", "labels"):
            (out / sub).mkdir(parents=True, exist_ok=True)
        probe = out / ".write-test.part"
        probe.write_bytes(b"x")
        probe.unlink()
    except OSError as exc:
        raise BadInput(f"{out}: cannot write the output folder: "
                       f"{exc.strerror or exc}") from None
    for leftover in out.rglob("*.part"):  # cut off by an earlier run
        leftover.unlink(missing_ok=True)


def run(args: argparse.Namespace) -> int:
    if args.workers is not None and args.workers < 1:
        raise BadInput(f"--workers: at least 1, not {args.workers}")
    if args.max_seconds is not None and not args.max_seconds > 0:
        raise BadInput(f"--max-seconds: a positive number, not {args.max_seconds}")
    if args.retries < 0:
        raise BadInput(f"--retries: 0 or more, not {args.retries}")
    out = Path(args.output)
    options = {"format": args.format, "quality": args.quality, "model": args.model,
               "max_seconds": args.max_seconds,
               "diagnostics": args.diagnostics, "labels": args.labels, "score_options": {},
               "stems": args.stems}
    plan = gather(args.inputs, options)
    if not plan.total:
        raise BadInput("no inputs found (scene .json, Guitar Pro, MusicXML, MIDI files or specs)")
    _prepare_output(out)
    old = read_manifest(out, args.manifest)
    rows: dict[str, dict[str, Any]] = {}
    skipped = 0

    def todo() -> Iterator[Item]:  # lazily: a spec's items are made as they are submitted
        nonlocal skipped
        for item in plan.items():
            if _is_done(old.get(item.id), item, out):
                rows[item.id] = old[item.id]
                skipped += 1
            else:
                yield item

    t0 = time.perf_counter()
    rendered = _submit_all(todo(), out, options, args, rows, plan.total)
    write_manifest(out, args.manifest, list(rows.values()))
    if len(rows) != plan.total:  # ids are unique by construction: this is a bug, never silent
        print(f"{len(rows)} manifest rows for {plan.total} items", file=sys.stderr)
        return 1
    failed = [r for r in rows.values() if r.get("status") != "done"]
    if not args.quiet:
        audio_s = sum(r.get("audio_seconds") or 0 for r in rendered)
        wall = time.perf_counter() - t0
        print(f"{plan.total - len(failed)} of {plan.total} items done ({skipped} skipped as "
              f"done before, {len(failed)} failed); {audio_s:.1f} s of audio rendered in "
              f"{wall:.1f} s; manifest {_manifest_path(out, args.manifest)}", file=sys.stderr)
    return 1 if failed else 0


IN_FLIGHT_PER_WORKER = 4  # items submitted ahead per Dask worker: they stay busy, memory flat


def _submit_all(todo: Iterator[Item], out: Path, options: dict, args: argparse.Namespace,
                rows: dict[str, dict[str, Any]], total: int) -> list[dict[str, Any]]:
    """Render the items of ``todo`` on Dask, a bounded number in flight at once (so a spec of
    millions of scenes is drawn and submitted as the workers take them); their rows go into
    ``rows``.  Returns the rows of the items rendered in this run.  The cluster is started only
    when there is something to do."""
    from dask.distributed import as_completed
    from tqdm import tqdm

    rendered: list[dict[str, Any]] = []
    first = next(todo, None)
    with tqdm(total=total, unit="item", file=sys.stderr, disable=args.quiet,
              dynamic_ncols=True) as bar:
        if first is None:
            bar.update(len(rows))
            return rendered
        client, cluster = connect(args.scheduler, args.workers)
        try:
            workers = max(1, len(client.scheduler_info().get("workers", {})))
            window = IN_FLIGHT_PER_WORKER * workers
            futures: dict[Any, Item] = {}
            pending = itertools.chain([first], todo)

            def submit(item: Item) -> Any:
                fut = client.submit(render_item, item, str(out.resolve()), options, key=(
                    f"render-{item.id}-{item.input_hash}"), retries=args.retries, pure=False,
                    priority=int(item.duration * 1000))
                futures[fut] = item
                return fut

            done = as_completed([submit(i) for i in itertools.islice(pending, window)])
            last = time.monotonic()
            shown = 0
            for fut in done:
                item = futures.pop(fut)
                try:
                    row = fut.result()
                except Exception as exc:  # KilledWorker: the item killed every worker it met
                    row = {"id": item.id, "input": item.input, "seed": item.seed,
                           "input_hash": item.input_hash, "status": "failed",
                           "error": _one_line(exc)}
                fut.release()
                rows[item.id] = row
                rendered.append(row)
                nxt = next(pending, None)
                if nxt is not None:
                    done.add(submit(nxt))
                bar.update(len(rows) - shown)
                shown = len(rows)
                if time.monotonic() - last > MANIFEST_INTERVAL_S:
                    write_manifest(out, args.manifest, list(rows.values()))
                    last = time.monotonic()
            bar.update(len(rows) - shown)
        finally:
            client.close()
            if cluster is not None:
                cluster.close()
    return rendered


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return run(args)
    except BadInput as exc:
        print(f"{parser.prog}: error: {exc}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"{parser.prog}: interrupted; run again to resume", file=sys.stderr)
        return 130
    except Exception as exc:  # a cluster that went away, a disk that filled up under the manifest
        print(f"{parser.prog}: error: {_one_line(exc)}; run again to resume", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
