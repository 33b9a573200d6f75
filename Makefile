# femcal: `make demo` and `make test` set up what is missing first (see `make setup`).
SHELL := /bin/bash
VENV := .venv
PY := $(VENV)/bin/python
STAMP := $(VENV)/.femcal-setup

.PHONY: setup demo test test-slow lint bench-parse bench-deck-edit bench-assembly bench-eigen bench-identify bench-identify-real bench-calibration bench-fuzz bench-scaling bench-pages bench-commits setup-slepc bench-slepc clean

setup: $(STAMP)

# System packages (root + apt only), the virtual environment and the package in editable mode.
# Re-runs only when pyproject.toml changes; quiet when everything is there.
$(STAMP): pyproject.toml
	@bash tools/setup.sh
	@touch $(STAMP)

# The main job, the reference study on the bundled truck frame: identify the shipped synthetic
# hammer test (72 x 2 FRFs), calibrate the hammer frame's 30 parameters against it (damping
# equalisation, identifiability, prior and posterior, surrogate, multi-start
# Levenberg-Marquardt), and write out/report.json, out/report.html with its pictures, the
# calibrated deck and out/identify/.
demo: setup
	@mkdir -p out
	$(VENV)/bin/femcal calibrate models/truck_frame/hammer_calibration.toml --out out

# The suite in TEST_WORKERS processes (pytest-xdist), a test file per process at a time so that
# its module-scoped fixtures are made once; one BLAS thread each, so that two processes share
# the 2-core target without oversubscribing it (OPENBLAS_CORETYPE is left as the machine sets
# it). TEST_WORKERS=0 runs in this process alone.
TEST_WORKERS ?= 2
PYTEST := OPENBLAS_NUM_THREADS=1 $(PY) -m pytest -q -n $(TEST_WORKERS) --dist loadfile

test: setup
	$(PYTEST) -m "not slow"

test-slow: setup
	$(PYTEST) -m slow

lint: setup
	$(VENV)/bin/ruff check src tests benchmarks

# Deck reading against pyNastran 1.4.1, which lives in its own environment (it pins NumPy < 2).
bench-parse: setup .venv-bench/.ok
	$(PY) benchmarks/parse.py

# The calibrated deck (the deck's own text, calibrated fields changed) read by femcal and by
# pyNastran to the same values and card counts.
bench-deck-edit: setup .venv-bench/.ok
	$(PY) benchmarks/calibrated_deck.py

bench-assembly: setup
	$(PY) benchmarks/assembly.py

bench-eigen: setup
	@command -v ccx >/dev/null || { [ "$$(id -u)" = 0 ] && apt-get install -y -qq calculix-ccx >/dev/null; } || true
	$(PY) benchmarks/eigen_vs_calculix.py

# Identification of the synthetic hammer test against its true modes, and sdypy-ema's LSCF on
# the same data (sdypy-ema lives in its own environment: benchmark only).
bench-identify: setup .venv-ema/.ok
	$(PY) benchmarks/identify_hammer.py

# femcal's pLSCF and subspace estimators and sdypy-ema's LSCF on the real measured sets of
# tests/data/real and two synthetic ones: modes found within the reference's accuracy, time.
bench-identify-real: setup .venv-ema/.ok
	$(PY) benchmarks/identify_real.py

# Calibration timing (per LM iteration, per start, whole run) and the noise-free recovery of the
# hammer frame's parameters.
bench-calibration: setup
	$(PY) benchmarks/calibration.py

# The calibration's starts and the design study's points on 1 and 2 workers: this process,
# local worker processes and a Dask LocalCluster (docs/scaling.md).
bench-scaling: setup
	$(PY) benchmarks/scaling.py

# Two commits side by side, run whole and alternating: the demo's calibration and the plate's
# normal modes at 242 k DOF with CalculiX once (make bench-commits OLD=<rev> [NEW=<rev>]).
bench-commits: setup
	@command -v ccx >/dev/null || { [ "$$(id -u)" = 0 ] && apt-get install -y -qq calculix-ccx >/dev/null; } || true
	$(PY) benchmarks/commits.py $(OLD) $(or $(NEW),HEAD) --calculix

# The report pages in headless Chromium at 1024 px: the verdict first, no sideways scrolling.
bench-pages: setup
	@command -v chromium >/dev/null || { [ "$$(id -u)" = 0 ] && apt-get install -y -qq chromium >/dev/null; } || true
	$(PY) benchmarks/pages.py $(PAGES)

# The optional SLEPc backend (femcal solve --backend slepc under mpirun): Debian's petsc4py,
# slepc4py (PETSc 3.18 with MUMPS) and Open MPI in .venv-slepc/ (as root, apt-get).
setup-slepc: .venv-slepc/.femcal-setup

.venv-slepc/.femcal-setup: pyproject.toml tools/setup_slepc.sh
	@bash tools/setup_slepc.sh
	@touch $@

# SLEPc on 1 and 2 ranks against the default solver: the clamped plate at 242k and 1 M DOF.
bench-slepc: setup setup-slepc
	$(PY) benchmarks/slepc_scaling.py

# The long fuzz run: mutated reference decks (10 000), FRF files, calibration configs and RPC III files; prints
# the outcomes per harness (0 crashes, hangs and wrong answers is the target).
bench-fuzz: setup
	$(PY) benchmarks/fuzz.py

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
