"""SOL 103 against closed-form answers: rigid bodies on springs through RBE2 and RBE3, a
cantilever beam, a simply supported plate, a solid cantilever. Each reference value's source
is given next to it."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.deck import read_deck
from femcal.errors import ModelError
from femcal.model.build import build_model
from femcal.solve.normal_modes import solve_normal_modes

HEAD = "SOL 103\nCEND\nMETHOD = 1\nSPC = 1\nBEGIN BULK\n"


def modes_of(write, text):
    head = HEAD if "SPC" in text else HEAD.replace("SPC = 1\n", "")  # no set without cards
    deck = read_deck(write(head + text + "ENDDATA\n"))
    modes, red = solve_normal_modes(build_model(deck))
    return modes, red


def rigid_body_deck(link: str) -> str:
    """A 2 t mass with inertia at grid 100 linked to 4 corner grids (+-a, +-b, 0), each held
    by springs k in x, y and z."""
    a, b = 400.0, 250.0
    lines = ["EIGRL   1                       6", "CONM2   1       100             2.0",
             "        1.+5            2.+5                    3.+5",
             "GRID    100             0.      0.      0."]  # fmt: skip
    corners = [(1, a, b), (2, -a, b), (3, -a, -b), (4, a, -b)]
    for gid, x, y in corners:
        lines.append(f"GRID,{gid},,{x},{y},0.")
        for c in (1, 2, 3):
            lines.append(f"CELAS2,{10 * gid + c},1000.,{gid},{c}")
    if link == "RBE2":
        lines.append("RBE2,500,100,123456,1,2,3,4")
    else:  # the reference grid follows the corners' translations, equal weights
        lines.append("RBE3,500,,100,123456,1.,123,1,2,+\n+,3,4")
        lines.append("SPC1,1,456,1,2,3,4")  # corner rotations carry nothing
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize("link", ["RBE2", "RBE3"])
def test_rigid_body_on_springs(write, link):
    # Rigid body on springs (e.g. Thomson, Theory of Vibration, ch. 6): with the springs at
    # the corners symmetric about the mass centre, the six modes uncouple:
    # translations 4k/m; rotation about z: k sum(x^2 + y^2) / Izz; about x: k sum(y^2) / Ixx;
    # about y: k sum(x^2) / Iyy.
    k, m, a, b = 1000.0, 2.0, 400.0, 250.0
    ixx, iyy, izz = 1e5, 2e5, 3e5
    expected = sorted(
        [4 * k / m] * 3 + [4 * k * (a * a + b * b) / izz, 4 * k * b * b / ixx, 4 * k * a * a / iyy]
    )
    modes, _ = modes_of(write, rigid_body_deck(link))
    assert modes.eigenvalues[:6] == pytest.approx(expected, rel=1e-9)


def test_cantilever_beam_frequencies(write):
    # Euler-Bernoulli cantilever: omega_n = (beta_n L)^2 sqrt(E I / (rho A L^4)),
    # beta_n L = 1.8751041, 4.6940911 (Blevins, Formulas for Natural Frequency, table 8-1).
    L, n = 1000.0, 40
    E, rho, A, I = 2.1e5, 7.85e-9, 100.0, 833.333
    grids = "\n".join(f"GRID,{i + 1},,{L * i / n},0.,0." for i in range(n + 1))
    bars = "\n".join(f"CBAR,{i + 1},1,{i + 1},{i + 2},0.,1.,0." for i in range(n))
    text = (f"EIGRL   1                       4\nPARAM,COUPMASS,1\n{grids}\n{bars}\n"
            f"PBAR,1,1,{A},{I},{I},{2 * I}\nMAT1,1,{E},,.3,{rho}\nSPC1,1,123456,1\n")  # fmt: skip
    modes, _ = modes_of(write, text)
    base = np.sqrt(E * I / (rho * A * L**4)) / (2 * np.pi)
    f = modes.frequencies_hz
    bending = np.sort(f)[[0, 2]]  # two bending planes are equal (I1 = I2)
    assert bending == pytest.approx([1.8751041**2 * base, 4.6940911**2 * base], rel=1e-3)


def test_simply_supported_plate(write):
    # Kirchhoff plate, simply supported on all edges: omega_mn = pi^2 (m^2/a^2 + n^2/b^2)
    # sqrt(D / (rho h)), D = E h^3 / (12 (1 - nu^2)) (Leissa, Vibration of Plates, NASA SP-160).
    # 48 x 32 CQUAD4 (12.5 mm, three times the thickness): the lumped mass and the residual
    # bending flexibility both lower the frequencies, which converge from below (measured
    # -0.88 / -1.29 / -0.71 % on 24 x 16, -0.43 / -0.56 / -0.31 % here).
    a, b, h, n = 600.0, 400.0, 4.0, (48, 32)
    E, nu, rho = 7.0e4, 0.33, 2.7e-9
    nx, ny = n
    lines = ["EIGRL   1                       3", "PSHELL,1,1,4.,1,,1", f"MAT1,1,{E},,{nu},{rho}"]
    gid = lambda i, j: j * (nx + 1) + i + 1  # noqa: E731
    for j in range(ny + 1):
        for i in range(nx + 1):
            lines.append(f"GRID,{gid(i, j)},,{a * i / nx},{b * j / ny},0.")
            if i in (0, nx) or j in (0, ny):
                lines.append(f"SPC1,1,3,{gid(i, j)}")
    for j in range(ny):
        for i in range(nx):
            g = gid(i, j)
            lines.append(f"CQUAD4,{j * nx + i + 1},1,{g},{g + 1},{g + nx + 2},{g + nx + 1}")
    lines.append("SPC1,1,126,1")  # in-plane rigid motion
    lines.append(f"SPC1,1,2,{gid(nx, 0)}")
    modes, _ = modes_of(write, "\n".join(lines) + "\n")
    D = E * h**3 / (12 * (1 - nu**2))
    f = lambda m, k: np.pi / 2 * (m**2 / a**2 + k**2 / b**2) * np.sqrt(D / (rho * h))  # noqa: E731
    assert modes.frequencies_hz[:3] == pytest.approx(
        sorted([f(1, 1), f(2, 1), f(1, 2)])[:3], rel=1e-2
    )


def test_solid_cantilever_first_bending(write):
    # Slender cantilever of CHEXA (20 x 2 x 2), nu = 0: first bending frequency of the
    # Euler-Bernoulli beam, 1.8751^2 sqrt(EI / (rho A L^4)) / (2 pi) (Blevins), within 1.5 %
    # (shear and the clamped root's 3D effects take a little).
    L, w, nx, nw = 400.0, 20.0, 20, 2
    E, rho = 2.1e5, 7.85e-9
    lines = ["EIGRL   1                       1", "PSOLID,1,1", f"MAT1,1,{E},,0.,{rho}"]
    m = nw + 1
    gid = lambda i, j, k: (i * m + j) * m + k + 1  # noqa: E731
    for i in range(nx + 1):
        for j in range(m):
            for k in range(m):
                lines.append(f"GRID,{gid(i, j, k)},,{L * i / nx},{w * j / nw},{w * k / nw}")
                if i == 0:
                    lines.append(f"SPC1,1,123,{gid(i, j, k)}")
    e = 0
    for i in range(nx):
        for j in range(nw):
            for k in range(nw):
                e += 1
                g = [gid(i, j, k), gid(i, j + 1, k), gid(i, j + 1, k + 1), gid(i, j, k + 1)]
                g2 = [
                    gid(i + 1, j, k),
                    gid(i + 1, j + 1, k),
                    gid(i + 1, j + 1, k + 1),
                    gid(i + 1, j, k + 1),
                ]
                lines.append(f"CHEXA,{e},1,{','.join(map(str, g + g2[:2]))}\n,{g2[2]},{g2[3]}")
    modes, _ = modes_of(write, "\n".join(lines) + "\n")
    I = w**4 / 12
    f1 = 1.8751041**2 * np.sqrt(E * I / (rho * w * w * L**4)) / (2 * np.pi)
    assert modes.frequencies_hz[0] == pytest.approx(f1, rel=1.5e-2)


def test_dependent_twice_is_an_error_naming_both(write):
    text = ("EIGRL   1                       1\nGRID,1\nGRID,2,,1.\nGRID,3,,2.\n"
            "RBE2,7,1,123456,2\nRBE2,8,3,123,2\nCONM2,1,1,,1.\n")  # fmt: skip
    with pytest.raises(ModelError, match=r"dependent twice, by RBE2 7 and by RBE2 8"):
        modes_of(write, text)


def test_spc_on_dependent_dof_is_an_error(write):
    text = "EIGRL   1                       1\nGRID,1\nGRID,2,,1.\nRBE2,7,1,123456,2\nSPC1,1,1,2\n"
    with pytest.raises(ModelError, match=r"both constrained .* and dependent \(RBE2 7\)"):
        modes_of(write, text)


def test_rigid_chain_is_resolved(write):
    # Mass at the end of a chain RBE2 1 -> 2 -> 3: the mass follows grid 1 rigidly, so a single
    # spring k at grid 1 gives omega^2 = k / m.
    text = ("EIGRL   1                       1\nGRID,1\nGRID,2,,1.\nGRID,3,,2.\n"
            "RBE2,7,1,123456,2\nRBE2,8,2,123456,3\nCONM2,1,3,,2.\nCELAS2,5,50.,1,1\n"
            "SPC1,1,23456,1\n")  # fmt: skip
    modes, red = modes_of(write, text)
    assert modes.eigenvalues[0] == pytest.approx(25.0)
    assert len(red.dependent) == 12


def test_autospc_reports_singular_rotations(write):
    # Rods give no rotational stiffness: AUTOSPC fixes the rotations and says which.
    text = ("EIGRL   1                       2\nGRID,1\nGRID,2,,1000.\nCROD,1,1,1,2\n"
            "PROD,1,1,10.\nMAT1,1,2.1+5,,.3,7.85-9\nSPC1,1,123456,1\nSPC1,1,23,2\n")  # fmt: skip
    modes, _ = modes_of(write, text)
    assert sorted(map(tuple, modes.autospc.tolist())) == [(2, 4), (2, 5), (2, 6)]
    E, rho, L = 2.1e5, 7.85e-9, 1000.0  # rod with lumped mass m/2 at the free end
    assert modes.eigenvalues[0] == pytest.approx((E * 10 / L) / (rho * 10 * L / 2))


def test_grid_point_weight_generator(write):
    # Two masses: 2 t at (100, 0, 0) with inertia, 1 t at (0, 300, 50): total 3 t, centre of
    # gravity (200/3, 100, 50/3); inertia about the CG by the parallel-axis theorem.
    from femcal.assembly import assemble
    from femcal.assembly.weight import weight_summary

    text = ("EIGRL   1                       1\nGRID,1,,100.,0.,0.\nGRID,2,,0.,300.,50.\n"
            "CONM2,1,1,,2.,,,,,+\n+,10.,,20.,,,30.\nCONM2,2,2,,1.\n")  # fmt: skip
    model = build_model(read_deck(write(HEAD + text + "ENDDATA\n")))
    ws = weight_summary(model, assemble(model).M)
    assert ws.mass == pytest.approx([3.0, 3.0, 3.0])
    cg = np.array([200 / 3, 100.0, 50 / 3])
    assert ws.cg[0, 1:] == pytest.approx(cg[1:]) and ws.cg[1, 0] == pytest.approx(cg[0])
    r = np.array([[100.0, 0, 0], [0, 300.0, 50.0]]) - cg
    m = np.array([2.0, 1.0])
    expected = np.diag([10.0, 20.0, 30.0]) + sum(
        mi * (ri @ ri * np.eye(3) - np.outer(ri, ri)) for mi, ri in zip(m, r, strict=True)
    )
    assert np.allclose(ws.inertia_cg, expected)


def test_weight_generator_reports_before_wtmass_and_about_the_origin_for_a_missing_grdpnt(
        tmp_path, capsys):  # fmt: skip
    """NASTRAN's generator prints the input's mass (two CONM2 of 100 with WTMASS 0.00259:
    200, not 0.518), and for a GRDPNT grid the deck lacks it warns and takes the origin;
    the solve still writes its JSON."""
    import json

    from femcal.cli import main

    deck = tmp_path / "d.bdf"
    deck.write_text("SOL 103\nCEND\nMETHOD = 1\nBEGIN BULK\nPARAM,WTMASS,0.00259\n"
                    "PARAM,GRDPNT,99\nEIGRL,1,,,4\nGRID,1,,0.,0.,0.\nGRID,2,,100.,0.,0.\n"
                    "CONM2,11,1,,100.\nCONM2,12,2,,100.\nCELAS1,21,1,1,1\nPELAS,1,1000.\n"
                    "CROD,31,2,1,2\nPROD,2,5,1.\nMAT1,5,2.1+5,,.3\nENDDATA\n")  # fmt: skip
    assert main(["solve", str(deck), "--json", str(tmp_path / "out.json")]) == 0
    captured = capsys.readouterr()
    assert "PARAM GRDPNT 99: no GRID 99 in the model" in captured.err
    assert "REFERENCE POINT = (0, 0, 0)" in captured.out
    weight = json.loads((tmp_path / "out.json").read_text())["weight"]
    assert weight["mass"] == pytest.approx([200.0] * 3, rel=1e-12)
    assert weight["reference"] == [0.0, 0.0, 0.0]


def cquad8_plate(omit: bool, mpc: bool) -> str:
    """A simply supported 6 x 4 CQUAD8 plate, 4.0 thick (the Leissa plate above). The first
    element's midside node on the plate edge y = 0 is either omitted (omit) or kept and tied
    by MPCs to the mean of its corners (mpc): the same kinematics."""
    mx = 13  # grid positions along x of quadratic_plate's 6 cells
    gid = lambda i, j: j * mx + i + 1  # noqa: E731
    text = quadratic_plate("CQUAD8", 6, 4, 4.0, lambda i, j: omit and (i, j) == (1, 0))
    lines = text.splitlines()
    if mpc:
        for comp in range(1, 7):
            if comp != 3:  # w of the edge node is already simply supported
                lines.append(
                    f"MPC,1,{gid(1, 0)},{comp},1.,{gid(0, 0)},{comp},-.5,\n,,{gid(2, 0)},{comp},-.5"
                )
    return "\n".join(lines) + "\n"


def test_simply_supported_plate_of_cquad8(write):
    # Leissa, as above: first mode within 1 % on 6 x 4 CQUAD8.
    a, b, h = 600.0, 400.0, 4.0
    E, nu, rho = 7.0e4, 0.33, 2.7e-9
    modes, _ = modes_of(write, cquad8_plate(omit=False, mpc=False))
    D = E * h**3 / (12 * (1 - nu**2))
    f11 = np.pi / 2 * (1 / a**2 + 1 / b**2) * np.sqrt(D / (rho * h))
    assert modes.frequencies_hz[0] == pytest.approx(f11, rel=1e-2)


def test_omitted_midside_node_is_a_straight_edge(write):
    # NASTRAN: an omitted midside node means the edge's motion is the mean of its corners.
    # Tying a present node by MPCs gives the same kinematics, but that element keeps MITC8's
    # two shear ties on the straight edge and locks; with the node omitted the shear follows
    # the straight edge (shell_quadratic: MITC8 -> MITC4 there). The omitted one is the
    # softer of the two (measured: 88.24 against 88.26 Hz tied; Leissa's f11 88.32 Hz).
    a, b, h = 600.0, 400.0, 4.0
    E, nu, rho = 7.0e4, 0.33, 2.7e-9
    f11 = np.pi / 2 * (1 / a**2 + 1 / b**2) * np.sqrt(E * h**2 / (12 * (1 - nu**2)) / rho)
    omitted, _ = modes_of(write, cquad8_plate(omit=True, mpc=False))
    deck_text = cquad8_plate(omit=False, mpc=True)
    deck = read_deck(write(HEAD.replace("SPC = 1\n", "SPC = 1\nMPC = 1\n") + deck_text
                           + "ENDDATA\n", "tied.bdf"))  # fmt: skip
    tied, _ = solve_normal_modes(build_model(deck))
    assert np.all(omitted.frequencies_hz[:3] < tied.frequencies_hz[:3])
    assert omitted.frequencies_hz[0] == pytest.approx(f11, rel=2e-3)


def quadratic_plate(kind: str, nx: int, ny: int, h: float, omit) -> str:
    """A simply supported 600 x 400 plate (the Leissa plate above) of nx x ny CQUAD8, or of
    CTRIA6 or CTRIA3 (each cell cut along its diagonal), with the midside nodes at grid
    positions (i, j) (the 2 nx + 1 by 2 ny + 1 grid of corners and edge midpoints) for which
    ``omit(i, j)`` is true left out of the elements and the deck (CTRIA3: all of them)."""
    a, b = 600.0, 400.0
    E, nu, rho = 7.0e4, 0.33, 2.7e-9
    lines = ["EIGRL   1                       3", f"PSHELL,1,1,{h},1,,1", f"MAT1,1,{E},,{nu},{rho}"]
    mx, my = 2 * nx + 1, 2 * ny + 1
    gid = lambda i, j: j * mx + i + 1  # noqa: E731
    quad = kind == "CQUAD8"
    mids = {(i, j) for j in range(my) for i in range(mx)
            if (i % 2 != j % 2) or (not quad and i % 2 and j % 2)}  # fmt: skip
    gone = {p for p in mids if kind == "CTRIA3" or omit(*p)}
    for j in range(my):
        for i in range(mx):
            if (i % 2 and j % 2 and quad) or (i, j) in gone:
                continue
            lines.append(f"GRID,{gid(i, j)},,{a * i / (mx - 1)},{b * j / (my - 1)},0.")
            if i in (0, mx - 1) or j in (0, my - 1):
                lines.append(f"SPC1,1,3,{gid(i, j)}")
    e = 0
    for j in range(0, my - 1, 2):
        for i in range(0, mx - 1, 2):
            c = [(i, j), (i + 2, j), (i + 2, j + 2), (i, j + 2)]
            m = [(i + 1, j), (i + 2, j + 1), (i + 1, j + 2), (i, j + 1)]
            d = (i + 1, j + 1)
            cells = [(c, m)] if quad else [(c[:3], [m[0], m[1], d]), ([c[0], c[2], c[3]], [d, m[2], m[3]])]
            for cn, mn in cells:
                e += 1
                nodes = [str(gid(*p)) for p in cn] + ["" if p in gone else str(gid(*p)) for p in mn]
                nodes = nodes[:3] if kind == "CTRIA3" else nodes
                lines.append(f"{kind},{e},1,{','.join(nodes[:6])}" + (f"\n,{','.join(nodes[6:])}" if quad else ""))
    lines.append("SPC1,1,126,1")
    lines.append(f"SPC1,1,2,{gid(mx - 1, 0)}")
    return "\n".join(lines) + "\n"


@pytest.mark.parametrize(
    ("kind", "pattern", "tol"),
    [("CQUAD8", "half", 0.01), ("CQUAD8", "all", 0.03), ("CTRIA6", "half", 0.04),
     ("CTRIA6", "all", 0.1), ("CTRIA3", "all", 0.03)],
)  # fmt: skip
def test_thin_plates_do_not_lock(write, kind, pattern, tol):
    # Leissa's f11 of the simply supported 600 x 400 plate on 6 x 4 cells with a random half
    # of the midside nodes omitted, or all of them (CQUAD8 then has MITC4's shear, CTRIA6
    # MITC3's, each with the residual bending flexibility of CQUAD4 / CTRIA3), and of CTRIA3,
    # 4.0 and 0.25 thick (elements 25 and 400 thicknesses long). Locking would make the thin
    # plate stiffer than the thick one; here both are off by the same. Measured, 4.0 / 0.25
    # thick: CQUAD8 half +0.13 / +0.18 %, all -2.26 / -2.23 %; CTRIA6 half +3.34 / +3.54 %,
    # all +8.37 / +8.43 % (+1.9 % on 12 x 8); CTRIA3 +2.02 / +2.07 %. Before the transition
    # shear fields and the CTRIA3's residual bending flexibility: +152 / +429 %,
    # +480 / +9036 %, +450 / +5953 %, +83 / +1537 % and +72 / +1421 %.
    a, b = 600.0, 400.0
    E, nu, rho = 7.0e4, 0.33, 2.7e-9
    flags = np.random.default_rng(0).random((13, 9)) < 0.5  # the (2 nx + 1, 2 ny + 1) grid

    def omit(i: int, j: int) -> bool:
        return pattern == "all" or bool(flags[i, j])

    ratio = []
    for h in (4.0, 0.25):
        f11 = np.pi / 2 * (1 / a**2 + 1 / b**2) * np.sqrt(E * h**2 / (12 * (1 - nu**2)) / rho)
        modes, _ = modes_of(write, quadratic_plate(kind, 6, 4, h, omit))
        ratio.append(modes.frequencies_hz[0] / f11)
    assert ratio[1] == pytest.approx(ratio[0], rel=0.005)
    assert ratio[1] == pytest.approx(1.0, rel=tol)


@pytest.mark.parametrize(("kind", "tol"), [("CTRIA3", 0.03), ("CTRIA6", 0.1)])
def test_shear_rigid_triangles_do_not_lock(write, kind, tol):
    # PSHELL without MID3 (no transverse shear flexibility: a Kirchhoff plate), the same
    # plate of CTRIA3, or of CTRIA6 with every midside node omitted. Its shear-rigid penalty
    # locked MITC3 (+408 % and +441 %); with the residual bending flexibility it is +2.07 % and
    # +8.43 %, the same as the shear-flexible thin plate above.
    a, b, h = 600.0, 400.0, 4.0
    E, nu, rho = 7.0e4, 0.33, 2.7e-9
    f11 = np.pi / 2 * (1 / a**2 + 1 / b**2) * np.sqrt(E * h**2 / (12 * (1 - nu**2)) / rho)
    text = quadratic_plate(kind, 6, 4, h, lambda i, j: True)
    text = text.replace(f"PSHELL,1,1,{h},1,,1", f"PSHELL,1,1,{h},1")
    modes, _ = modes_of(write, text)
    assert modes.frequencies_hz[0] == pytest.approx(f11, rel=tol)
