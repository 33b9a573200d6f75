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

missing=()
if command -v dpkg >/dev/null 2>&1; then
    for pkg in libsuitesparse-dev libopenblas0-pthread; do
        dpkg -s "$pkg" >/dev/null 2>&1 || missing+=("$pkg")
    done
elif ! have_cholmod_headers; then
    missing+=(libsuitesparse-dev)
fi
if [ ${#missing[@]} -gt 0 ]; then
    if [ "$(id -u)" = "0" ] && command -v apt-get >/dev/null 2>&1; then
        say "installing ${missing[*]} with apt-get"
        export DEBIAN_FRONTEND=noninteractive
        apt-get update -qq >/dev/null
        apt-get install -y -qq "${missing[@]}" >/dev/null
    else
        say "missing ${missing[*]} and no root/apt-get: CHOLMOD may be skipped (SuperLU fallback)"
    fi
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
