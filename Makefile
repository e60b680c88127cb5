# The README's Quick start is `make serve` and `make test`; CI runs `.ci/run`, which calls `make test`.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
# numba writes its compiled kernels here (one cache for the tests, the service and its workers)
export NUMBA_CACHE_DIR ?= $(CURDIR)/.numba_cache

# Debian packages, installed only when we are root and they are missing (a fresh machine or CI).
APT_INSTALL = apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq
IS_ROOT = [ "$$(id -u)" = 0 ]

.PHONY: install venv-support serve test test-fast test-data lint browser docker-check docker-tools bench-tools bench \
        bench-service bench-live bench-batch clean

install: $(VENV)/.warm

# Debian's python3 leaves ensurepip (hence `python3 -m venv`) to the python3-venv package.
venv-support:
	@$(PY) -c 'import ensurepip' 2>/dev/null || { $(IS_ROOT) && \
	  $(APT_INSTALL) python3-venv >/dev/null ; } || \
	  { echo "$(PY) cannot create a venv: apt-get install python3-venv" >&2; exit 1; }

$(VENV)/.installed: pyproject.toml | venv-support
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[dev]'
	touch $@

# Then the caches a first render would wait for (engine/precompile.py): the compiled kernels, in
# NUMBA_CACHE_DIR (the service's and the tests') and in numba's default place (a plain
# `guitar-synth render`), and the fret calibrations of every preset.  Both are keyed by the engine's
# sources, so an update that changes them (a pull, a checkout) warms them again here instead of in
# the first render after it; when nothing changed this stamp is newer and nothing runs.  And the
# bytecode of our own modules: pip compiles an installed package's, not an editable one's, and
# where PYTHONDONTWRITEBYTECODE is set every process would compile them again (each CLI render
# and each worker's start).
PRODUCT_SOURCES := $(shell find engine cli service -name '*.py' -not -path '*/__pycache__/*')
$(VENV)/.warm: $(VENV)/.installed $(PRODUCT_SOURCES)
	$(BIN)/python -m compileall -q engine cli service
	$(BIN)/python -m engine.precompile
	env -u NUMBA_CACHE_DIR $(BIN)/python -m engine.precompile --kernels-only
	touch $@

# `make serve HOST=0.0.0.0 PORT=8080` to listen elsewhere; the service writes its own JSON access
# log, uvicorn's would duplicate every line
HOST ?= 127.0.0.1
PORT ?= 8000
serve: install
	$(BIN)/uvicorn service.app:app --host $(HOST) --port $(PORT) --no-access-log

# Debian's chromium drives the demo-page test (PyPI's playwright talks to it; never `playwright
# install`).  Installed when we are root and it is missing; without it that one test is skipped.
browser:
	@command -v chromium >/dev/null 2>&1 || { $(IS_ROOT) && \
	  $(APT_INSTALL) chromium >/dev/null ; } || \
	  echo "chromium is not installed: the browser test will be skipped"

lint: install
	$(BIN)/ruff check .
	$(BIN)/hadolint Dockerfile

# Third-party score files for tests/engine/score (never committed; .cache/ is git-ignored): the test
# corpus in PyGuitarPro's sdist, and the MIDI test files in music21's and miditoolkit's sdists.
# Only those packages are fetched as sources (--no-binary names them); their build tools as wheels.
SCORE_CORPUS := .cache/score-corpus
SCORE_SDISTS := PyGuitarPro==0.11 music21==9.1.0 miditoolkit==1.0.1

test-data: $(SCORE_CORPUS)/.done

$(SCORE_CORPUS)/.done: scripts/score_corpus.py | install
	rm -rf $(SCORE_CORPUS) && mkdir -p $(SCORE_CORPUS)/sdist
	$(BIN)/pip download -q --no-deps --no-binary PyGuitarPro,music21,miditoolkit \
	  -d $(SCORE_CORPUS)/sdist $(SCORE_SDISTS)
	$(BIN)/python scripts/score_corpus.py $(SCORE_CORPUS)
	touch $@

test: install browser lint test-data
	$(BIN)/pytest -q

# The loop a developer runs all day: everything but the tests marked slow, on two processes
# (pytest-xdist), first failure stops it.
test-fast: install test-data
	$(BIN)/pytest -q -x -n 2 -m "not slow"

# Builds the Docker image without a Docker engine (podman/buildah, chroot isolation) and checks
# /health and a render inside it; needs root.  See scripts/docker-check.
docker-tools:
	@command -v podman >/dev/null 2>&1 && command -v buildah >/dev/null 2>&1 && \
	  command -v debootstrap >/dev/null 2>&1 || { $(IS_ROOT) && \
	  $(APT_INSTALL) podman buildah debootstrap >/dev/null ; } || \
	  { echo "docker-check needs root and: apt-get install podman buildah debootstrap" >&2; exit 2; }

docker-check: docker-tools
	scripts/docker-check

# Debian's FluidSynth and General MIDI SoundFont: benchmarks/scores.py renders the same notes with
# them to compare speed and what a pitch tracker hears.  Installed when we are root and missing;
# without them that comparison is left out of the tables.
bench-tools:
	@{ command -v fluidsynth >/dev/null 2>&1 && [ -e /usr/share/sounds/sf2/FluidR3_GM.sf2 ]; } || \
	  { $(IS_ROOT) && $(APT_INSTALL) fluidsynth fluid-soundfont-gm >/dev/null ; } || \
	  echo "fluidsynth is not installed: benchmarks/scores.py will leave FluidSynth out"

bench: install test-data bench-tools
	$(BIN)/python -m benchmarks.run_all

# Latency, time to first byte and throughput of the service over real HTTP (uvicorn on a free port).
bench-service: install
	$(BIN)/python benchmarks/service_bench.py

# Live play over a websocket: latency, underruns, sessions per core (about four minutes).
bench-live: install
	$(BIN)/python benchmarks/live.py

# guitar-synth batch on Dask: 1 and 2 local workers against one process, and a corpus projection.
bench-batch: install
	$(BIN)/python -m benchmarks.batch

clean:
	rm -rf $(VENV) .numba_cache .pytest_cache .ruff_cache
