# femcal: `make demo` and `make test` set up what is missing first (see `make setup`).
SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.femcal-setup

.PHONY: setup demo test test-slow lint bench-parse bench-assembly bench-eigen bench-identify clean

setup: $(STAMP)

# System packages (root + apt only), the virtual environment and the package in editable mode.
# Re-runs only when pyproject.toml changes; quiet when everything is there.
$(STAMP): pyproject.toml
	@bash tools/setup.sh
	@touch $(STAMP)

# The main job: the bundled truck frame on air bellows (the reference study's hammer-test
# frame): its summary, normal modes to 150 Hz (table on the console and in
# out/hammer_frame/eigenvalues.txt, JSON, NPZ, VTU for ParaView) and a picture per mode.
demo: setup
	@mkdir -p out
	$(VENV)/bin/femcal info models/truck_frame/hammer_frame.bdf --json out/hammer_frame_info.json
	$(VENV)/bin/femcal solve models/truck_frame/hammer_frame.bdf --json out/hammer_frame_modes.json \
		--out out/hammer_frame --png out/hammer_frame/png

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

# Identification of the synthetic hammer test against its true modes, and sdypy-ema's LSCF on
# the same data (sdypy-ema lives in its own environment: benchmark only).
bench-identify: setup .venv-ema/.ok
	$(PY) benchmarks/identify_hammer.py

.venv-ema/.ok:
	python3 -m venv .venv-ema
	.venv-ema/bin/python -m pip install -q 'sdypy-ema==0.31.0'
	@touch $@

.venv-bench/.ok:
	python3 -m venv .venv-bench
	.venv-bench/bin/python -m pip install -q 'pyNastran==1.4.1'
	@touch $@

clean:
	rm -rf out .pytest_cache build src/*.egg-info benchmarks/_work
