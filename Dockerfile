# The guitar synthesis service: uvicorn serving service.app:app on port 8000.
#
# BASE_IMAGE is any image with Python 3.11 and the venv module. Docker users keep the default;
# scripts/docker-check passes a Debian bookworm image it builds itself (python3, python3-venv).
ARG BASE_IMAGE=python:3.11-slim
FROM ${BASE_IMAGE}

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    VIRTUAL_ENV=/opt/venv \
    PATH=/opt/venv/bin:$PATH \
    PYTHONPATH=/app \
    NUMBA_CACHE_DIR=/var/cache/guitar/numba \
    GUITAR_CACHE_DIR=/var/cache/guitar \
    GUITAR_DATA_DIR=/var/lib/guitar

# A fixed numeric id, so that USER resolves without the image's passwd file.
RUN groupadd --system --gid 10001 app \
    && useradd --system --uid 10001 --gid 10001 --home-dir /app --no-create-home \
       --shell /usr/sbin/nologin app \
    && mkdir -p /app "$NUMBA_CACHE_DIR" "$GUITAR_DATA_DIR" \
    && chown 10001:10001 "$GUITAR_CACHE_DIR" "$NUMBA_CACHE_DIR" "$GUITAR_DATA_DIR"

# Jobs (SQLite and their results) live here: mount a volume to keep them across containers.
VOLUME /var/lib/guitar

WORKDIR /app

# Dependencies first, from pyproject.toml alone, so code changes do not reinstall them.
# (The wheels bring their own libsndfile and LLVM: no apt packages are needed.)
COPY pyproject.toml ./
RUN python3 -m venv "$VIRTUAL_ENV" \
    && python -c "import tomllib; print('\n'.join(tomllib.load(open('pyproject.toml', 'rb'))['project']['dependencies']))" > /tmp/requirements.txt \
    && pip install --no-cache-dir -r /tmp/requirements.txt \
    && rm /tmp/requirements.txt

COPY engine/ engine/
COPY service/ service/
COPY static/ static/

# The bytecode of our modules, written while /app is still root's (the app user cannot write
# there, and PYTHONDONTWRITEBYTECODE is set): without it every worker compiles them at start.
RUN python -m compileall -q engine service

USER 10001:10001

# Compile the numba kernels now, into NUMBA_CACHE_DIR, so that workers start in about a second
# instead of compiling for 10-15 s each. (The cache is keyed to this CPU's features; on another
# CPU model the workers compile once at start-up and write the cache again: it stays writable.)
# Calibrate the frets of every preset for offline renders at the default quality (same command).
# And calibrate the frets of the guitar a live worker prepares when it warms up (the default
# guitar at 44.1 and 48 kHz, on both models: the finite-difference frets, the waveguide's finger
# damping of every held fret) into GUITAR_CACHE_DIR, so that a live worker does not spend seconds
# calibrating every fret (engine.calibration_store; benchmarks/calibration.py).
RUN python -m engine.precompile \
    && python -c "import engine; [engine.Session(sample_rate=r, model=m) for r in (44100, 48000) for m in engine.MODELS]"

EXPOSE 8000

# Workers warm up at start-up; /health answers 200 only once every one of them is ready.
HEALTHCHECK --interval=30s --timeout=5s --start-period=120s --retries=3 \
    CMD ["python", "-c", "import sys, urllib.request; sys.exit(urllib.request.urlopen('http://127.0.0.1:8000/health', timeout=4).status != 200)"]

# The service writes its own JSON access log; uvicorn's would duplicate it.
CMD ["uvicorn", "service.app:app", "--host", "0.0.0.0", "--port", "8000", "--no-access-log"]
