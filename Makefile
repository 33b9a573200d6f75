# femcal: `make demo` and `make test` set up what is missing first (see `make setup`).
SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.femcal-setup

.PHONY: setup demo test test-slow lint bench clean

setup: $(STAMP)

# System packages (root + apt only), the virtual environment and the package in editable mode.
# Re-runs only when pyproject.toml changes; quiet when everything is there.
$(STAMP): pyproject.toml
	@bash tools/setup.sh
	@touch $(STAMP)

demo: setup
	@mkdir -p out
	$(VENV)/bin/femcal info models/examples/ladder_frame.bdf --json out/ladder_frame_info.json

test: setup
	$(PY) -m pytest -m "not slow" -q

test-slow: setup
	$(PY) -m pytest -m slow -q

lint: setup
	$(VENV)/bin/ruff check src tests benchmarks

bench: setup
	$(PY) benchmarks/parse.py

clean:
	rm -rf out .pytest_cache build src/*.egg-info
