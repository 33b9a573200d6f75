# femcal: `make demo` and `make test` set up what is missing first (see `make setup`).
SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.femcal-setup

.PHONY: setup demo test test-slow lint bench-parse bench-assembly bench-eigen clean

setup: $(STAMP)

# System packages (root + apt only), the virtual environment and the package in editable mode.
# Re-runs only when pyproject.toml changes; quiet when everything is there.
$(STAMP): pyproject.toml
	@bash tools/setup.sh
	@touch $(STAMP)

# The most complete job so far: read the bundled example, solve its normal modes, write the
# table, JSON, NPZ, VTU (ParaView) and a picture per mode to out/.
demo: setup
	@mkdir -p out
	$(VENV)/bin/femcal info models/examples/ladder_frame.bdf --json out/ladder_frame_info.json
	$(VENV)/bin/femcal solve models/examples/ladder_frame.bdf --json out/ladder_frame_modes.json \
		--out out/ladder_frame --png out/ladder_frame/png

test: setup
	$(PY) -m pytest -m "not slow" -q

test-slow: setup
	$(PY) -m pytest -m slow -q

lint: setup
	$(VENV)/bin/ruff check src tests benchmarks

# Deck reading against pyNastran 1.4.1, which lives in its own environment (it pins NumPy < 2).
bench-parse: setup .venv-bench/.ok
	$(PY) benchmarks/parse.py

bench-assembly: setup
	$(PY) benchmarks/assembly.py

bench-eigen: setup
	@command -v ccx >/dev/null || { [ "$$(id -u)" = 0 ] && apt-get install -y -qq calculix-ccx >/dev/null; } || true
	$(PY) benchmarks/eigen_vs_calculix.py

.venv-bench/.ok:
	python3 -m venv .venv-bench
	.venv-bench/bin/python -m pip install -q 'pyNastran==1.4.1'
	@touch $@

clean:
	rm -rf out .pytest_cache build src/*.egg-info benchmarks/_work
