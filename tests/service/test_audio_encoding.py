"""service.audio: the hand-written WAV agrees with libsndfile, and block-wise equals whole-file."""

from __future__ import annotations

import io

import numpy as np
import pytest
import soundfile as sf

from service import audio

RATE = 44100


@pytest.fixture
def signal() -> np.ndarray:
    rng = np.random.default_rng(7)
    x = rng.uniform(-1.2, 1.2, 5000)  # beyond full scale on purpose: must be clipped
    x[:4] = [1.0, -1.0, 0.0, 1.5]
    return x


@pytest.mark.parametrize("subtype,lsb", [("PCM_16", 2**-15), ("PCM_24", 2**-23), ("FLOAT", 1e-7)])
def test_wav_decodes_to_the_clipped_signal(signal: np.ndarray, subtype: str, lsb: float) -> None:
    data = audio.encode(signal, RATE, "wav", subtype)
    info = sf.info(io.BytesIO(data))
    y, rate = sf.read(io.BytesIO(data), dtype="float64")
    assert (info.format, info.subtype, info.channels, rate) == ("WAV", subtype, 1, RATE)
    assert len(y) == len(signal)
    assert np.max(np.abs(y - np.clip(signal, -1, 1))) <= lsb
    assert len(data) == audio.wav_size(len(signal), subtype)


@pytest.mark.parametrize("subtype", ["PCM_16", "PCM_24"])
def test_integer_samples_equal_libsndfiles(signal: np.ndarray, subtype: str) -> None:
    # The same conversion as soundfile's own writer, so either decoder sees identical integers.
    ours = audio.encode(signal, RATE, "wav", subtype)
    buf = io.BytesIO()
    sf.write(buf, np.clip(signal, -1, 1), RATE, format="WAV", subtype=subtype)
    theirs = buf.getvalue()
    assert ours[:4] == b"RIFF" and ours[8:16] == b"WAVEfmt "
    assert ours[-len(signal) * audio.BYTES_PER_SAMPLE[subtype]:] == \
        theirs[-len(signal) * audio.BYTES_PER_SAMPLE[subtype]:]


@pytest.mark.parametrize("subtype", ["PCM_16", "PCM_24", "FLOAT"])
def test_header_plus_blocks_equal_the_whole_file(signal: np.ndarray, subtype: str) -> None:
    whole = audio.encode(signal, RATE, "wav", subtype)
    blocks = [signal[i:i + 777] for i in range(0, len(signal), 777)]
    streamed = audio.wav_header(len(signal), RATE, subtype) + b"".join(
        audio.pcm_bytes(b, subtype) for b in blocks)
    assert streamed == whole


@pytest.mark.parametrize("fmt,subtype,expect", [
    ("flac", "PCM_16", "PCM_16"), ("flac", "PCM_24", "PCM_24"), ("flac", "FLOAT", "PCM_24"),
    ("ogg", "PCM_16", "VORBIS"),
])
@pytest.mark.parametrize("rate", [22050, 44100, 96000])
def test_flac_and_ogg(fmt: str, subtype: str, expect: str, rate: int) -> None:
    t = np.arange(rate // 4) / rate
    x = 0.5 * np.sin(2 * np.pi * 440 * t)
    data = audio.encode(x, rate, fmt, subtype)
    info = sf.info(io.BytesIO(data))
    assert (info.format, info.subtype, info.samplerate) == (fmt.upper(), expect, rate)
    y, _ = sf.read(io.BytesIO(data))
    if fmt == "flac":
        assert len(y) == len(x)
    else:  # Vorbis may pad or trim a little at the ends
        assert abs(len(y) - len(x)) < 2048
    assert np.all(np.isfinite(y))


@pytest.mark.parametrize("subtype", ["PCM_16", "PCM_24", "FLOAT"])
def test_stereo_wav_interleaves_and_streams_the_same(signal: np.ndarray, subtype: str) -> None:
    x = np.stack([signal, -0.5 * signal], axis=1)  # (frames, 2): left, right
    whole = audio.encode(x, RATE, "wav", subtype, channels=2)
    y, _ = sf.read(io.BytesIO(whole), dtype="float64")
    assert y.shape == x.shape and sf.info(io.BytesIO(whole)).channels == 2
    assert np.max(np.abs(y - np.clip(x, -1, 1))) <= 2**-15
    assert len(whole) == audio.wav_size(len(x), subtype, channels=2)
    streamed = audio.wav_header(len(x), RATE, subtype, channels=2) + b"".join(
        audio.pcm_bytes(x[i:i + 1000], subtype) for i in range(0, len(x), 1000))
    assert streamed == whole
    if subtype != "FLOAT":  # the same integers as libsndfile's own stereo writer
        buf = io.BytesIO()
        sf.write(buf, np.clip(x, -1, 1), RATE, format="WAV", subtype=subtype)
        n = x.size * audio.BYTES_PER_SAMPLE[subtype]
        assert whole[-n:] == buf.getvalue()[-n:]


def test_empty_stereo_render_still_has_a_stereo_header() -> None:
    data = audio.encode(np.zeros(0), RATE, "wav", "PCM_16", channels=2)
    assert sf.info(io.BytesIO(data)).channels == 2 and len(data) == 44
