"""Small decks for the calibration tests: a cantilevered plate with a stiffener bar, a rod,
a tip mass, a bush and a spring, every kind of calibration parameter in a few hundred DOF."""

from __future__ import annotations

from pathlib import Path

import numpy as np

#: The plate's nine parameters as the noise-free tests make them (p = P / P0 - 1).
TRUE_P = np.array([0.08, -0.05, 0.06, 0.1, -0.1, 0.12, 0.2, -0.15, 0.1])
#: The tests' sensors and inputs on the plate deck.
OUTS = [*(f"{g}:+Z" for g in (3, 5, 7, 10, 12, 14, 17, 19, 21, 24, 26, 28)), "28:+X", "14:+Y"]
INS = ["28:+Z", "11:+Y"]


def plate_deck(nx: int = 6, ny: int = 3, *, lx: float = 600.0, ly: float = 300.0) -> str:
    """SOL 103 deck (mm, tonne, s): a 5 mm steel plate clamped along x = 0, a CBAR stiffener
    along y = 0, a CROD brace, a CONM2 at the free corner, a CBUSH and a CELAS1 to ground at
    the free edge."""
    lines = ["SOL 103", "CEND", "METHOD = 1", "SPC = 1", "BEGIN BULK", "EIGRL,1,,,12",
             "MAT1,1,210000.,,.3,7.85-9", "MAT1,2,70000.,,.33,2.7-9",
             "PSHELL,1,1,5.,1,,1", "PBAR,2,2,120.,900.,1600.,2000.",
             "PROD,3,1,30.,50.", "PBUSH,4,K,40.,50.,60.,0.,0.,0.", "PELAS,5,25."]  # fmt: skip
    gid = lambda i, j: 1 + i + (nx + 1) * j  # noqa: E731
    for j in range(ny + 1):
        for i in range(nx + 1):
            lines.append(f"GRID,{gid(i, j)},,{lx * i / nx!r},{ly * j / ny!r},0.")
    eid = 1
    for j in range(ny):
        for i in range(nx):
            lines.append(f"CQUAD4,{eid},1,{gid(i, j)},{gid(i + 1, j)},{gid(i + 1, j + 1)},"
                         f"{gid(i, j + 1)}")  # fmt: skip
            eid += 1
    for i in range(nx):
        lines.append(f"CBAR,{100 + i},2,{gid(i, 0)},{gid(i + 1, 0)},0.,0.,1.")
    lines.append(f"CROD,200,3,{gid(nx, 0)},{gid(nx - 2, ny)}")
    lines.append(f"CONM2,300,{gid(nx, ny)},,0.002")
    lines.append(f"GRID,900,,{lx!r},{ly / 2!r},-50.")
    lines.append(f"CBUSH,400,4,{gid(nx, ny // 2)},900,,,,0")
    lines.append(f"CELAS1,500,5,{gid(nx, 1)},3")
    lines.append("SPC1,1,123456,900")
    lines.append("SPC1,1,123456," + ",".join(str(gid(0, j)) for j in range(ny + 1)))
    lines.append("ENDDATA")
    return "\n".join(lines) + "\n"


PARAMS_TOML = """
[[parameter]]
name = "t"
card = "PSHELL"
id = 1
field = "T"
lower_rel = -0.2
upper_rel = 0.2

[[parameter]]
name = "E_steel"
card = "MAT1"
id = 1
field = "E"
lower_rel = -0.2
upper_rel = 0.2

[[parameter]]
name = "rho_steel"
card = "MAT1"
id = 1
field = "RHO"
lower_rel = -0.2
upper_rel = 0.2

[[parameter]]
name = "A_bar"
card = "PBAR"
id = 2
field = "A"
lower_rel = -0.2
upper_rel = 0.2

[[parameter]]
name = "I1_bar"
card = "PBAR"
id = 2
field = "I1"
lower_rel = -0.2
upper_rel = 0.2

[[parameter]]
name = "A_rod"
card = "PROD"
id = 3
field = "A"
lower_rel = -0.2
upper_rel = 0.2

[[parameter]]
name = "k_bush"
card = "PBUSH"
id = 4
field = "K3"
lower_rel = -0.5
upper_rel = 0.5

[[parameter]]
name = "k_spring"
card = "PELAS"
id = 5
field = "K"
lower_rel = -0.5
upper_rel = 0.5

[[parameter]]
name = "m_tip"
card = "CONM2"
id = 300
field = "M"
lower_rel = -0.5
upper_rel = 0.5
"""



#: The parameters of the plate carrying a load (a CONM2 301 at grid 17, added to the plate
#: deck): two of the plate's (t, rho_steel) and the load's mass.
LOADED_PARAMS = "".join(
    "\n[[parameter]]" + block for block in PARAMS_TOML.split("[[parameter]]")
    if 'name = "t"' in block or 'name = "rho_steel"' in block) + """
[[parameter]]
name = "m_load"
card = "CONM2"
id = 301
field = "M"
lower_rel = -0.5
upper_rel = 0.5
"""


def write_plate(folder: Path):
    """Write ``plate.bdf`` and ``p.toml`` (all nine parameters) into ``folder``; return the
    deck's model and the parameters."""
    from femcal.calibrate.parameters import read_parameters
    from femcal.model.build import load_model

    (folder / "plate.bdf").write_text(plate_deck())
    (folder / "p.toml").write_text(PARAMS_TOML)
    model = load_model(folder / "plate.bdf")
    return model, read_parameters(folder / "p.toml", model)


def write_modal_test(path: Path, truth, outs: list[str], ins: list[str]) -> list:
    """A noise-free test of the model ``truth``: its accelerances (40 modes, modal damping
    0.02, 2-750 Hz every 0.25 Hz) at ``outs`` for ``ins`` (``GRID:+C`` labels), written as
    NPZ to ``path``; returns the output channels."""
    from femcal.model import EigenRequest
    from femcal.response.frf import channel_matrix, modal_frf
    from femcal.solve.normal_modes import solve_normal_modes
    from femcal.testdata.data import Channel, FRFData
    from femcal.testdata.formats.npz import write_npz

    modes, _ = solve_normal_modes(truth, request=EigenRequest(nd=40))
    o = [Channel.parse(x) for x in outs]
    i = [Channel.parse(x) for x in ins]
    f = np.arange(2.0, 750.0, 0.25)
    H = modal_frf(modes.shapes, modes.radians, channel_matrix(truth, o),
                  channel_matrix(truth, i).T, f, 0.02, "accelerance")  # fmt: skip
    write_npz(path, FRFData(f, H, tuple(o), tuple(i), "accelerance", "mm/s^2/N"))
    return o
