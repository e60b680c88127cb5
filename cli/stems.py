"""Stems as files: each string of each track in a file of its own beside the mix.

    song.wav  ->  song.stems/t1-s6.wav ... t1-s1.wav, t2-s4.wav ..., song.stems/stems.json

One mono file per string (``t<track>-s<string>``, tracks from 1 in the scene's order, strings
numbered as the scene numbers them, 1 = highest), in the mix's format and subtype: as SynthTab
renders a tab string by string, and with no channel limit (FLAC holds at most eight).  Every string
of a track has a file, a silent one too, so a track's files are its hexaphonic pickup.
``stems.json`` lists them in the labels' order (each stem's ``annotation``: its ``note_midi``
annotation's index in the JAMS file), with the ``gain`` they share with the mix.

A stem is the string's pickup velocity before pan, body and effects, times its track's fader, at
the mix's gain (``engine.mix``): the stems sum to the dry mix.  Under ``normalize`` that gain (the
one that puts the loudest of the mix and the stems at -1 dBFS) is known only when all is seen,
so the stems are kept as float64 in a spill file beside their folder until then, and scaled into
place block by block: a song's stems are never held in memory.  At the fixed gain, samples beyond
full scale are clipped, as the mix's are; ``clipped`` counts them.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import numpy as np

SPILL_BLOCK = 1 << 16  # frames read back at a time


def stems_folder(output: str | Path) -> Path:
    """``song.wav`` -> ``song.stems``."""
    p = Path(output)
    return p.with_name(p.stem + ".stems")


def file_subtype(fmt: str, subtype: str) -> str:
    """The soundfile subtype a file of ``fmt`` gets for the scene's ``subtype`` (as the mix's)."""
    if fmt == "flac":
        return "PCM_16" if subtype == "PCM_16" else "PCM_24"
    if fmt == "ogg":
        return "VORBIS"
    return subtype


class StemWriter:
    """Writes a render's stems block by block into ``folder``.  ``start`` takes what the columns
    are (``engine.Stem``s), ``write`` each block of stems, (frames, len(layout)), in any unit;
    each file holds them times ``gain``, given here when it is known before the render
    (``normalize: false``) or to ``close`` after it.  ``input_scale``: what the blocks written
    are per m/s (``engine.FIXED_GAIN`` for ``engine.blocks``, 1 for ``render_result``'s
    ``on_stems``), for ``stems.json``'s gain."""

    def __init__(self, folder: Path, rate: int, fmt: str, subtype: str,
                 gain: float | None = None, input_scale: float = 1.0):
        self.folder = Path(folder)
        self.input_scale = input_scale
        self.rate = rate
        self.fmt = fmt
        self.clipped = 0
        self.peak = 0.0  # the largest magnitude written, in the blocks' unit
        self.layout: list[Any] = []
        self.paths: list[Path] = []
        self._gain = gain
        self._subtype = subtype
        self._spill = None
        self._files: list[Any] = []

    def start(self, layout: list[Any]) -> None:
        import soundfile as sf

        self.layout = layout
        gain, fmt, rate, subtype = self._gain, self.fmt, self.rate, self._subtype
        self.folder.mkdir(parents=True, exist_ok=True)
        self.paths = [self.folder / f"{s.label}.{fmt}" for s in layout]
        if gain is None:
            self._spill_path = self.folder.with_name(self.folder.name + ".part")
            self._spill = open(self._spill_path, "wb")  # noqa: SIM115 (closed in close/abort)
        else:
            self._files = [sf.SoundFile(str(_part(p)), "w", samplerate=rate, channels=1,
                                        format=fmt.upper(), subtype=file_subtype(fmt, subtype))
                           for p in self.paths]

    def write(self, block: np.ndarray) -> None:
        if block.size:
            self.peak = max(self.peak, float(np.max(np.abs(block))))
        if self._spill is not None:
            self._spill.write(np.ascontiguousarray(block, dtype="<f8").tobytes())
        else:
            self._write_scaled(block, self._gain)

    def _write_scaled(self, block: np.ndarray, gain: float) -> None:
        x = block * gain
        self.clipped += int(np.count_nonzero(np.abs(x) > 1.0))
        x = np.clip(x, -1.0, 1.0)
        for k, f in enumerate(self._files):
            f.write(np.ascontiguousarray(x[:, k]))

    def close(self, gain: float | None = None) -> list[Path]:
        """Finish the files (scaled by ``gain`` when it was not known at the start; ignored when
        it was), rename them into place, write ``stems.json``; the files written."""
        import soundfile as sf

        import engine

        if self._spill is not None:
            if gain is None:
                raise ValueError("the stems' gain is needed to finish them")
            self._spill.close()
            self._spill = None
            self._files = [sf.SoundFile(str(_part(p)), "w", samplerate=self.rate, channels=1,
                                        format=self.fmt.upper(),
                                        subtype=file_subtype(self.fmt, self._subtype))
                           for p in self.paths]
            width = len(self.layout)
            if width and os.path.getsize(self._spill_path):
                data = np.memmap(self._spill_path, dtype="<f8", mode="r").reshape(-1, width)
                for at in range(0, len(data), SPILL_BLOCK):
                    self._write_scaled(np.array(data[at:at + SPILL_BLOCK]), gain)
                del data
            self._spill_path.unlink()
            self._gain = gain
        for f in self._files:
            f.close()
        for p in self.paths:
            os.replace(_part(p), p)
        index = self.folder / "stems.json"
        info = engine.stems_index(self.layout, self.fmt, self.rate,
                                  self.input_scale * (self._gain or 0.0), self.clipped)
        index.write_text(json.dumps(info, indent=1) + "\n", encoding="utf-8")
        return [*self.paths, index]

    def abort(self) -> None:
        """Close and remove what was written (a render that failed)."""
        if self._spill is not None:
            self._spill.close()
            self._spill_path.unlink(missing_ok=True)
        for f in self._files:
            f.close()
        for p in self.paths:
            _part(p).unlink(missing_ok=True)


def _part(p: Path) -> Path:
    return p.with_name(p.name + ".part")
