"""Scores imported lately, kept in the API process: one file with one set of options is imported
by a worker once, not once a request.

The demo page reads a score (``POST /score/scene``, then ``/score/labels``) and plays it
(``POST /jobs`` or ``/render/score``): three imports of the same file, each seconds long for a
whole song, and the last one stands between the click on Play and the first sound.

An entry is the worker's answer as it came (the scene's JSON bytes and the importer's warnings),
keyed by the file's SHA-256, its name and the importer's options other than ``max_seconds``.  A
request with ``max_seconds`` M takes an entry whose scene plays at most M s: the importer's cut
leaves such a scene as it is (``engine.performance.truncate``), so the answer is the one the
worker would give.  Likewise an import with ``max_seconds`` is kept only when its scene came out
shorter than M (it was not cut).  An entry with more events than a request allows is not used: the
worker refuses that request in its own words.  The entries are bounded by their bytes, the least
lately used going first (``GUITAR_SCORE_CACHE_MB``; 0 keeps none).
"""

from __future__ import annotations

import hashlib
import json
from collections import OrderedDict
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class Imported:
    raw: bytes  # the scene's JSON
    warnings: tuple[str, ...]
    duration: float
    events: int


class ScoreCache:
    def __init__(self, max_bytes: int):
        self.max_bytes = max_bytes
        self._entries: OrderedDict[str, Imported] = OrderedDict()
        self._bytes = 0
        self.hits = 0
        self.misses = 0

    @staticmethod
    def key(data: bytes, name: str, options: dict[str, Any]) -> str:
        rest = {k: v for k, v in options.items() if k != "max_seconds"}
        text = json.dumps([name, rest], sort_keys=True, default=repr)
        return hashlib.sha256(hashlib.sha256(data).digest() + text.encode()).hexdigest()

    def get(self, key: str, options: dict[str, Any], max_events: int) -> Imported | None:
        """The import of ``key`` if it answers a request with ``options`` and ``max_events``."""
        entry = self._entries.get(key)
        most = options.get("max_seconds")
        if entry is None or entry.events > max_events or (most is not None
                                                          and entry.duration > most):
            self.misses += 1
            return None
        self._entries.move_to_end(key)
        self.hits += 1
        return entry

    def put(self, key: str, options: dict[str, Any], raw: bytes, meta: dict[str, Any]) -> None:
        """Keep a worker's import (``meta``: its ``warnings``, ``duration`` and ``events``), unless
        ``max_seconds`` cut it or it alone would fill the cache."""
        most = options.get("max_seconds")
        duration, events = meta.get("duration"), meta.get("events")
        if duration is None or events is None or len(raw) > self.max_bytes // 2:
            return
        if most is not None and not duration < most:
            return  # cut (or exactly as long as the cut): not the file's whole scene
        old = self._entries.pop(key, None)
        if old is not None:
            self._bytes -= len(old.raw)
        self._entries[key] = Imported(raw, tuple(meta.get("warnings") or ()), float(duration),
                                      int(events))
        self._bytes += len(raw)
        while self._bytes > self.max_bytes:
            _, gone = self._entries.popitem(last=False)
            self._bytes -= len(gone.raw)

    def __len__(self) -> int:
        return len(self._entries)
