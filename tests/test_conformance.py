"""SOL 103 conformance: every tier A and B reference deck against its NASTRAN run.

Modes marked valid are matched in order: within 0.1 % for decks of rods, bars, beams,
springs, masses and rigid elements, within 1 % for decks with shells or solids; reference
modes near zero (below 1e-3 of the highest) must come out below that too. Tier C decks must
solve or fail with a message naming what is not supported.

Decks that do not meet their tolerance yet are listed in KNOWN_GAPS with the error measured
and what is missing; they are strict xfails, so fixing one makes the suite say so.
"""

from __future__ import annotations

import numpy as np
import pytest

from femcal.deck import read_deck
from femcal.errors import FemcalError
from femcal.model.build import build_model
from femcal.solve.normal_modes import solve_normal_modes

from .conftest import refdeck_cases

SHELL_SOLID = {"CQUAD4", "CTRIA3", "CQUAD8", "CTRIA6", "CQUADR", "CTRIAR", "CSHEAR", "CHEXA",
               "CPENTA", "CTETRA", "CPYRAM"}  # fmt: skip

#: deck -> why it does not meet its tolerance yet (measured worst error in the text).
KNOWN_GAPS = {
    "pyn_trncomp12": "modes 4-29 up to +158 % (mode 8): the deck's modes measure six elements' "
    "coarse-mesh formulations more than the plate. It is a 720 x 360 laminated plate 0.1 thick "
    "meshed with six elements 180-360 long (CQUADR, CTRIAR, and CQUAD8 / CTRIA6 with omitted "
    "midside nodes), R3 fixed everywhere by GRID PS. benchmarks/trncomp12_convergence.py solves "
    "the same plate on 64 x 64 x 2 CTRIA3: NX's own six elements are -21..+84 % from the "
    "converged bending modes (its modes 1-9) and -17..+37 % from the converged membrane ones "
    "(its modes 10-19); femcal's are -21..+371 % and 0..+96 %. Matching NX here means matching "
    "its formulations of quadratic shells with omitted midside nodes and of CQUADR/CTRIAR with "
    "fixed drilling rotations. No shear locking is left (scaling the transverse shear by 1e-3 "
    "or 1e3 moves modes 8-9 under 5 %). The membrane modes hang on the drilling treatment: "
    "mode 10 is +44 % with the Allman membranes, +6 % with CQUAD4/CTRIA3 membranes in their "
    "place (modes 10-29 then within 22 %), -35 % without any drilling penalty",
    "pyn_tet10_simple": "23 % (mode 5): two 10-node tetrahedra, clamped at one corner and "
    "three midside nodes. The stiffness is NASTRAN's: with the 5-point rule femcal reproduces "
    "the f06's 0 Hz response (residual vectors on, so the static K^-1 F) in all 27 components "
    "to 9e-8 of the largest, NASTRAN's print precision (test_tet10_static_response_matches_"
    "nastran). The modes "
    "differ in the mass: NASTRAN's frequencies lie between femcal's with HRZ-lumped (-7..-23 %) "
    "and consistent (+9..+40 %) mass, and no mass tried fits all ten modes: a corner/midside "
    "split, a blend of the two, consistent masses integrated at 1, 4 or 5 points or lumped "
    "from them, massless corners with free midside masses, or any element mass with the "
    "tetrahedron's symmetry (seven free entries), whose best fit leaves 3 % at a total mass "
    "of 1.21 x rho V. Not matched",
}

CASES = [
    pytest.param(*c, id=c[0], marks=[pytest.mark.xfail(strict=True, reason=KNOWN_GAPS[c[0]])]
                 if c[0] in KNOWN_GAPS else [])
    for c in refdeck_cases()
    if c[2].get("tier") in ("A", "B")
]  # fmt: skip
TIER_C = [c for c in refdeck_cases() if c[2].get("tier") == "C"]


def tolerance(ref: dict) -> float:
    cards = set(ref["deck"]["card_count"])
    return 1e-2 if cards & SHELL_SOLID else 1e-3


def worst_error(name, main, ref) -> tuple[float, int]:
    deck = read_deck(main)
    modes, _ = solve_normal_modes(build_model(deck))
    f = modes.frequencies_hz
    valid = [m for m in ref["modes"] if m["valid"]]
    assert len(f) >= len(valid), f"{len(f)} modes computed, {len(valid)} in the reference"
    fmax = max(m["cycles_hz"] for m in valid)
    worst, at = 0.0, 0
    for m in valid:
        ours, theirs = f[m["mode"] - 1], m["cycles_hz"]
        if theirs < 1e-3 * fmax:
            assert abs(ours) < 1e-3 * fmax, f"mode {m['mode']}: {ours} Hz, NASTRAN {theirs} Hz"
            continue
        err = abs(ours / theirs - 1.0)
        if err > worst:
            worst, at = err, m["mode"]
    return worst, at


@pytest.mark.parametrize(("name", "main", "ref"), CASES)
def test_tier_a_b_decks_match_nastran(name, main, ref):
    worst, at = worst_error(name, main, ref)
    print(f"{name}: worst {worst:.2e} at mode {at} (tolerance {tolerance(ref):.0e})")
    assert worst <= tolerance(ref), f"mode {at}: relative error {worst:.3e}"


@pytest.mark.parametrize(("name", "main", "ref"), TIER_C, ids=[c[0] for c in TIER_C])
def test_tier_c_decks_solve_or_say_why(name, main, ref):
    try:
        deck = read_deck(main)
        modes, _ = solve_normal_modes(build_model(deck))
    except FemcalError as e:
        assert "not supported" in str(e) or "not implemented" in str(e), str(e)
    else:
        f = modes.frequencies_hz
        assert np.isfinite(f).all()
        valid = [m["cycles_hz"] for m in ref["modes"] if m["valid"]]
        if valid and max(valid) < 1e-4:  # NASTRAN found mechanisms only: so must femcal
            assert len(f) >= len(valid) and np.abs(f[: len(valid)]).max() < 1e-4, f[:5]


#: NASTRAN's 0 Hz response of pyn_tet10_simple to FORCE 30 (1.0 along x at GRID 2154): the
#: "COMPLEX DISPLACEMENT VECTOR" at FREQUENCY = 0.0 of pyNastran's
#: models/complex/tet10/simple_example.f06 (MSC.Nastran 2005.1, SOL 111, page 16). Residual
#: vectors are on, so the modal response spans K^-1 F and the 0 Hz one is the static K^-1 F.
TET10_STATIC = {
    2136: (1.258036e-05, 7.695964e-07, 1.294139e-05),
    2154: (4.340456e-05, -1.289517e-05, 4.163720e-05),
    2161: (1.790950e-06, 3.298141e-06, -2.531172e-06),
    2191: (8.735060e-06, -2.023279e-06, 1.029112e-05),
    2259: (-4.626278e-08, -8.466152e-07, -2.370280e-06),
    2485: (-1.601899e-06, -2.378052e-06, 4.837875e-06),
    2486: (4.112244e-06, 1.731911e-06, 4.172349e-06),
    2487: (2.421974e-05, -4.759638e-06, 2.368923e-05),
    2503: (-1.301535e-06, -4.054202e-06, -7.301098e-07),
    2534: (3.151078e-06, -6.841077e-06, 1.593433e-05),
}


def test_tet10_static_response_matches_nastran():
    """Both elements are curved (GRID 2534 is 2.7 % of its edge off the midpoint), so the
    response depends on the stiffness rule: NASTRAN's is matched to print precision (9e-8 of
    the largest displacement) by the 5-point (degree 3) rule, where the 4-point rule is off by
    1.4 % and an exact rule by 0.9 %."""
    from femcal.assembly import assemble
    from femcal.assembly.constraints import autospc, build_reduction

    deck = read_deck(next(c[1] for c in refdeck_cases() if c[0] == "pyn_tet10_simple"))
    model = build_model(deck)
    mats = assemble(model)
    red = build_reduction(model)
    red = autospc(model, red, red.reduce(mats.K), red.reduce(mats.M), enabled=True)
    K_aa = red.reduce(mats.K).toarray()
    dof = {(g, c): model.dof_start[i] + c for i, g in enumerate(model.node_ids) for c in range(3)}
    f = np.zeros(model.n_dof)
    f[dof[2154, 0]] = 1.0
    u = np.asarray(red.T @ np.linalg.solve(K_aa, red.T.T @ f)).ravel()
    ours = np.array([[u[dof[g, c]] for c in range(3)] for g in TET10_STATIC])
    theirs = np.array(list(TET10_STATIC.values()))
    assert np.abs(ours - theirs).max() < 1e-6 * np.abs(theirs).max()


def test_fmondsp_rigid_body_mass_matches_nastran_gpwg():
    """NASTRAN's grid point weight generator output for pyn_fmondsp (pyNastran
    models/aero/fmondsp.f06, MSC.Nastran 2005.1, page 17: MO about the origin). Its tubes
    taper, so the lumped CBEAM mass shows how each member's mass is shared between its ends:
    the centre-keeping shares give NASTRAN's MO to 7e-7, half each would be 1.4e-3 off."""
    from femcal.assembly import assemble
    from femcal.assembly.weight import weight_summary

    deck = read_deck(next(c[1] for c in refdeck_cases() if c[0] == "pyn_fmondsp"))
    model = build_model(deck)
    MO = weight_summary(model, assemble(model).M).MO
    nastran = {(0, 0): 3.304377e02, (3, 3): 3.061525e03, (4, 4): 8.622872e02,
               (5, 5): 3.864383e03, (1, 5): 3.301281e02, (0, 4): 1.220670e01,
               (3, 5): -7.324020e01}  # fmt: skip
    for (i, j), value in nastran.items():
        assert MO[i, j] == pytest.approx(value, rel=2e-6), (i, j)
