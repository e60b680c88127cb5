# The README's Quick start is `make serve` and `make test`; CI runs `.ci/run`, which calls `make test`.
PY ?= python3
VENV := .venv
BIN := $(VENV)/bin
# numba writes its compiled kernels here (one cache for the tests, the service and its workers)
export NUMBA_CACHE_DIR ?= $(CURDIR)/.numba_cache

.PHONY: install serve test lint browser bench bench-quick clean

install: $(VENV)/.installed

$(VENV)/.installed: pyproject.toml
	$(PY) -m venv $(VENV)
	$(BIN)/pip install -q --upgrade pip
	$(BIN)/pip install -q -e '.[dev]'
	touch $@

serve: install
	$(BIN)/uvicorn service.app:app --host 127.0.0.1 --port 8000

# Debian's chromium drives the demo-page test (PyPI's playwright talks to it; never `playwright
# install`).  Installed when we are root and it is missing; without it that one test is skipped.
browser:
	@command -v chromium >/dev/null 2>&1 || { [ "$$(id -u)" = 0 ] && \
	  (apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium >/dev/null) ; } || \
	  echo "chromium is not installed: the browser test will be skipped"

lint: install
	$(BIN)/ruff check .

test: install browser lint
	$(BIN)/pytest -q

bench: install
	$(BIN)/python -m benchmarks.run_all

clean:
	rm -rf $(VENV) .numba_cache .pytest_cache .ruff_cache
