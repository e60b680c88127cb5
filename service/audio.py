"""Encoding samples (mono or stereo) to bytes: WAV by hand, FLAC and Ogg Vorbis through soundfile.

WAV is written here rather than by libsndfile for two reasons:
* a stream must send its header before any sample exists, and ``/render`` must produce the very same
  bytes, so both go through one header function and one sample conversion (``pcm_bytes``);
* libsndfile adds a ``PEAK`` chunk (peak values and a time stamp) to float WAV files, which a
  stream cannot know in advance and which would make two renders of one scene differ.

The integer conversion is libsndfile 1.2's: round x * 2^31 to int32 (saturating), keep the top 16
or 24 bits.  Samples are clipped to [-1, 1] first, everywhere (the fixed-gain output may exceed it).
"""

from __future__ import annotations

import io
import json
import struct
import zipfile
from typing import IO, Any

import numpy as np
import soundfile as sf

MEDIA_TYPES = {"wav": "audio/wav", "flac": "audio/flac", "ogg": "audio/ogg"}
BYTES_PER_SAMPLE = {"PCM_16": 2, "PCM_24": 3, "FLOAT": 4}
_WAVE_FORMAT_PCM = 1
_WAVE_FORMAT_IEEE_FLOAT = 3


def clip(x: np.ndarray) -> np.ndarray:
    return np.clip(x, -1.0, 1.0)


def pcm_bytes(x: np.ndarray, subtype: str) -> bytes:
    """Little-endian sample bytes of a block, shape (frames,) or (frames, channels), for a WAV
    ``data`` chunk (row-major order interleaves the channels as WAV wants)."""
    x = clip(np.asarray(x, dtype=np.float64))
    if subtype == "FLOAT":
        return x.astype("<f4").tobytes()
    i32 = np.clip(np.rint(x * 2.0**31), -(2.0**31), 2.0**31 - 1).astype(np.int64)
    if subtype == "PCM_16":
        return (i32 >> 16).astype("<i2").tobytes()
    if subtype == "PCM_24":
        # Keep the low three bytes of each little-endian int32 holding the top 24 bits.
        top = (i32 >> 8).astype("<i4")
        return top.view(np.uint8).reshape(-1, 4)[:, :3].tobytes()
    raise ValueError(f"unsupported WAV subtype {subtype!r}")


def wav_header(frames: int, sample_rate: int, subtype: str, channels: int = 1) -> bytes:
    """RIFF/WAVE header of a file of ``frames`` frames (known before any sample is computed)."""
    width = BYTES_PER_SAMPLE[subtype]
    block_align = width * channels
    data_bytes = frames * block_align
    is_float = subtype == "FLOAT"
    fmt = struct.pack(
        "<HHIIHH",
        _WAVE_FORMAT_IEEE_FLOAT if is_float else _WAVE_FORMAT_PCM,
        channels,
        sample_rate,
        sample_rate * block_align,  # byte rate
        block_align,
        8 * width,  # bits per sample
    )
    chunks = b"fmt " + struct.pack("<I", len(fmt)) + fmt
    if is_float:  # non-PCM WAV files carry a fact chunk with the frame count
        chunks += b"fact" + struct.pack("<II", 4, frames)
    chunks += b"data" + struct.pack("<I", data_bytes)
    return b"RIFF" + struct.pack("<I", 4 + len(chunks) + data_bytes) + b"WAVE" + chunks


def wav_size(frames: int, subtype: str, channels: int = 1) -> int:
    header = wav_header(frames, 44100, subtype, channels)
    return len(header) + frames * channels * BYTES_PER_SAMPLE[subtype]


def as_frames(x: np.ndarray, channels: int) -> np.ndarray:
    """Samples as (frames,) for mono or (frames, channels), whatever shape an empty render has."""
    x = np.asarray(x, dtype=np.float64)
    if channels == 1:
        return x.reshape(-1)
    return x.reshape(-1, channels)


def _soundfile_bytes(x: np.ndarray, sample_rate: int, fmt: str, subtype: str) -> bytes:
    buf = io.BytesIO()
    sf.write(buf, clip(x), sample_rate, format=fmt.upper(), subtype=subtype)
    return buf.getvalue()


def encode(x: np.ndarray, sample_rate: int, fmt: str = "wav", subtype: str = "PCM_16",
           channels: int = 1) -> bytes:
    """A whole signal, shape (frames,) or (frames, channels), as a file: ``wav`` (subtype
    PCM_16/PCM_24/FLOAT), ``flac`` or ``ogg``.

    ``subtype`` is a WAV option (API.md); FLAC keeps 24 bits when PCM_24 or FLOAT is asked for and
    16 otherwise, Ogg is always Vorbis.
    """
    x = as_frames(x, channels)
    if fmt == "wav":
        return wav_header(len(x), sample_rate, subtype, channels) + pcm_bytes(x, subtype)
    if fmt == "flac":
        return _soundfile_bytes(x, sample_rate, "flac", "PCM_16" if subtype == "PCM_16" else "PCM_24")
    if fmt == "ogg":
        return _soundfile_bytes(x, sample_rate, "ogg", "VORBIS")
    raise ValueError(f"unsupported format {fmt!r}")


def media_type(fmt: str, stems: bool) -> str:
    """A response's media type: the format's, or a zip's when it carries stems."""
    return "application/zip" if stems else MEDIA_TYPES[fmt]


def stems_zip(mix: bytes, spill: IO[bytes], layout: list[Any], gain: float, sample_rate: int,
              fmt: str, subtype: str, name: str = "guitar") -> bytes:
    """A zip of the mix (``NAME.FMT``, the bytes given) and its stems, as the command line
    writes them (``stems/t1-s6.FMT`` ..., ``stems/stems.json``: ``engine.stems_index``).
    ``spill`` holds the stems as float64 rows of len(layout) columns in m/s (``on_stems``);
    each is scaled by ``gain``, the mix's, and encoded as the mix is (clipped at full scale)."""
    import engine

    width = len(layout)
    size = spill.seek(0, io.SEEK_END)
    # mapped, not read: the pages of a column come and go as the system sees fit
    rows = np.memmap(spill, dtype="<f8", mode="r").reshape(-1, width) if width and size else \
        np.zeros((0, width))
    buf = io.BytesIO()
    clipped = 0
    # PCM of silent strings deflates to nothing; FLAC and Vorbis are compressed already
    mode = zipfile.ZIP_DEFLATED if fmt == "wav" else zipfile.ZIP_STORED
    with zipfile.ZipFile(buf, "w", mode, compresslevel=1 if fmt == "wav" else None) as z:
        z.writestr(f"{name}.{fmt}", mix)
        for k, stem in enumerate(layout):
            x = rows[:, k] * gain
            clipped += int(np.count_nonzero(np.abs(x) > 1.0))
            z.writestr(f"stems/{stem.label}.{fmt}", encode(x, sample_rate, fmt, subtype))
        info = engine.stems_index(layout, fmt, sample_rate, gain, clipped)
        z.writestr("stems/stems.json", json.dumps(info, indent=1) + "\n")
    return buf.getvalue()
