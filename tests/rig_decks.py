"""A small frame on six oil columns, for the rig tests."""
from pathlib import Path


def small_rig_deck(path: Path) -> Path:
    """A steel beam along X (CBAR, 11 grids, 1000 mm) with an offset arm (RBE2 from grid 6 to
    grid 12 at y = 200) on six actuator springs to grounded grids: Z at 1, 11 and 12, Y at 1
    and 11, X at 1 (in the -X direction)."""
    lines = ["SOL 103", "CEND", "SPC = 1", "BEGIN BULK",
             "MAT1,1,210000.,,.3,7.85-9",
             "PBAR,1,1,400.,20000.,30000.,15000.",
             "PBUSH,21,K,3000.,0.,0.,0.,0.,0.", "PBUSH,22,K,0.,3000.,0.,0.,0.,0.",
             "PBUSH,23,K,0.,0.,3000.,0.,0.,0.",
             "CONM2,900,12,,0.002"]
    for i in range(11):
        lines.append(f"GRID,{i + 1},,{100.0 * i},0.,0.")
    for i in range(10):
        lines.append(f"CBAR,{i + 1},1,{i + 1},{i + 2},0.,0.,1.")
    lines.append("GRID,12,,500.,200.,0.")
    lines.append("RBE2,50,6,123456,12")
    ends = [(1, 0.0, 0.0, -50.0, 23), (11, 1000.0, 0.0, -50.0, 23),
            (12, 500.0, 200.0, -50.0, 23), (1, 0.0, -50.0, 0.0, 22),
            (11, 1000.0, -50.0, 0.0, 22), (1, -50.0, 0.0, 0.0, 21)]
    for k, (g, x, y, z, pid) in enumerate(ends):
        gid = 101 + k
        lines.append(f"GRID,{gid},,{x},{y},{z}")
        lines.append(f"CBUSH,{200 + k},{pid},{g},{gid},,,,0")
        lines.append(f"SPC1,1,123456,{gid}")
    lines.append("ENDDATA")
    path.write_text("\n".join(lines) + "\n")
    return path


ACTUATORS = [("A_z1", 1, 3), ("A_z11", 11, 3), ("A_z12", 12, 3), ("A_y1", 1, 2),
             ("A_y11", 11, 2), ("A_x1", 1, -1)]
SENSORS = [("S3", 3, 3), ("S8", 8, 2), ("S12", 12, 3), ("S11", 11, -1)]
