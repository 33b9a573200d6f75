#!/usr/bin/env bash
# Install what femcal needs, and nothing that is already there.
#  1. Debian packages (only as root with apt-get): libsuitesparse-dev for CHOLMOD, and
#     libopenblas0-pthread so that CHOLMOD's supernodal factorisation runs on OpenBLAS
#     rather than the reference BLAS (about 3x faster factorisations).
#  2. A virtual environment in .venv/ with `pip install -e .[dev,dask]` (Dask: the optional
#     distributed engine, used by the test suite).
#  3. scikit-sparse 0.4.16 (CHOLMOD) when SuiteSparse headers exist; otherwise femcal
#     runs with SciPy's SuperLU and this script says so.
set -euo pipefail
cd "$(dirname "$0")/.."

say() { echo "setup: $*"; }

have_cholmod_headers() {
    [ -f /usr/include/suitesparse/cholmod.h ] || [ -f /usr/include/cholmod.h ]
}

# shellcheck source=tools/apt.sh
. tools/apt.sh
if command -v dpkg >/dev/null 2>&1; then
    apt_install libsuitesparse-dev libopenblas0-pthread \
        || say "missing $APT_MISSING and no root/apt-get: CHOLMOD may be skipped (SuperLU fallback)"
elif ! have_cholmod_headers; then
    say "missing libsuitesparse-dev and no dpkg: CHOLMOD may be skipped (SuperLU fallback)"
fi

if [ ! -x .venv/bin/python ]; then
    say "creating .venv"
    python3 -m venv .venv
fi

say "installing femcal and its dependencies into .venv"
.venv/bin/python -m pip install -q --upgrade pip >/dev/null
.venv/bin/python -m pip install -q -e '.[dev,dask]'

if have_cholmod_headers; then
    if ! .venv/bin/python -c "import sksparse.cholmod" >/dev/null 2>&1; then
        say "building scikit-sparse 0.4.16 (CHOLMOD)"
        # Its build needs numpy and Cython in the build environment.
        if ! .venv/bin/python -m pip install -q 'scikit-sparse==0.4.16'; then
            say "scikit-sparse did not build: SuperLU fallback in use"
        fi
    fi
else
    say "CHOLMOD not available: SuperLU fallback in use"
fi
