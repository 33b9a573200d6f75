#!/usr/bin/env bash
# The optional SLEPc eigensolver backend (femcal solve --backend slepc, under mpirun) in its
# own environment, .venv-slepc/, and nothing that is already there.
#
# petsc4py and slepc4py come from Debian (python3-petsc4py, python3-slepc4py: PETSc 3.18 with
# MUMPS, SLEPc 3.18, Open MPI). They are built for Debian's Python and NumPy, not for the
# project's .venv, so .venv-slepc is a venv of /usr/bin/python3 that sees the system's
# packages (numpy, scipy, petsc4py, slepc4py) and gets femcal in editable mode without
# upgrading them, plus the few pure-Python packages `femcal solve` needs to run and write
# its files (threadpoolctl, tqdm, meshio). Pictures (--png, --gif, --html) are made with
# .venv. Run as root on Debian (apt-get); otherwise it says what is missing.
set -euo pipefail
cd "$(dirname "$0")/.."

say() { echo "setup-slepc: $*"; }
VENV=.venv-slepc
PY=/usr/bin/python3
PACKAGES=(python3-petsc4py python3-slepc4py python3-numpy python3-scipy python3-mpi4py
          python3-venv openmpi-bin)

if ! command -v dpkg >/dev/null 2>&1; then
    say "not a Debian system (no dpkg): install PETSc, SLEPc, petsc4py, slepc4py and MPI"
    say "yourself, or use Debian's ${PACKAGES[*]}"
    exit 1
fi
# shellcheck source=tools/apt.sh
. tools/apt.sh
if ! apt_install "${PACKAGES[@]}"; then
    say "missing Debian packages $APT_MISSING: run this as root (apt-get install -y" \
        "$APT_MISSING), then again"
    exit 1
fi

# Debian's petsc4py/slepc4py live under /usr/lib/{petsc,slepc}dir/<version>/<arch>/ and are
# found through the /usr/lib/petsc and /usr/lib/slepc links that only the -dev packages make;
# a .pth file in the venv points at the newest real-number build instead.
petsc_site=$(ls -d /usr/lib/petscdir/petsc3.*/x86_64-linux-gnu-real/lib/python3/dist-packages \
             2>/dev/null | sort -V | tail -1)
slepc_site=$(ls -d /usr/lib/slepcdir/slepc3.*/x86_64-linux-gnu-real/lib/python3/dist-packages \
             2>/dev/null | sort -V | tail -1)
if [ -z "$petsc_site" ] || [ -z "$slepc_site" ]; then
    say "petsc4py or slepc4py not found under /usr/lib/petscdir or /usr/lib/slepcdir"
    exit 1
fi

if [ ! -x "$VENV/bin/python" ]; then
    say "creating $VENV (Debian's Python, with its packages)"
    "$PY" -m venv --system-site-packages "$VENV"
fi
[ -f "$VENV/.gitignore" ] || echo '*' > "$VENV/.gitignore"  # git leaves the whole folder alone
site=$("$VENV/bin/python" -c "import sysconfig; print(sysconfig.get_paths()['purelib'])")
pth="$site/femcal-petsc.pth"
want=$(printf '%s\n%s\n' "$petsc_site" "$slepc_site")
if [ ! -f "$pth" ] || [ "$(cat "$pth")" != "$want" ]; then
    printf '%s\n' "$want" > "$pth"
fi

# pip's output goes to a log, shown only when it fails (it warns that femcal's plotting
# dependencies are absent, which is meant).
pip_quietly() {
    local log
    log=$(mktemp)
    if ! "$VENV/bin/python" -m pip install -q "$@" >"$log" 2>&1; then
        cat "$log" >&2
        rm -f "$log"
        say "pip install $* failed"
        exit 1
    fi
    rm -f "$log"
}

# femcal's own dependencies (numpy, scipy) are Debian's: --no-deps keeps pip from upgrading
# them; the pure-Python ones `femcal solve` imports are added without touching numpy.
if ! "$VENV/bin/python" -c "import femcal, threadpoolctl, tqdm, meshio" >/dev/null 2>&1; then
    say "installing femcal (editable) and threadpoolctl, tqdm, meshio into $VENV"
    pip_quietly --no-deps -e .
    # (their own requirements are met by Debian's numpy, so pip leaves it alone)
    pip_quietly 'threadpoolctl>=3.1' 'tqdm>=4.60' 'meshio>=5.3'
fi

if ! "$VENV/bin/python" -c "
from femcal.solve.slepc import petsc_modules
PETSc, SLEPc = petsc_modules()
" >/dev/null 2>&1; then
    say "petsc4py/slepc4py do not import in $VENV:"
    "$VENV/bin/python" -c "from femcal.solve.slepc import petsc_modules; petsc_modules()"
    exit 1
fi
