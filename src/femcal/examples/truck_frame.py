"""The bundled truck ladder frames (mm, tonne, s, N, MPa) as NASTRAN SOL 103 decks.

Two side rails (C-sections, web 255 x flanges 90 x 8 mm) with a 5 mm inner liner nested in
each, 860 mm apart, joined by cross members of different kinds through attachment brackets,
as in the reference study (see ../shared/METHOD.md). The hammer-test frame (3500 mm, on air
bellows) has four:

* X1, front: C-channel (4 mm) on welded end plates (6 mm), bolted through liner and rail;
* X2: rectangular tube (5 mm) on cast brackets of CHEXA solids (E = 164 000 MPa);
* X3: C-channel (7 mm) on end plates (7 mm) with triangular gussets (CQUAD4 with CTRIA3
  along the hypotenuse);
* X4: C-channel (10 mm) on end plates (8 mm), 675 mm ahead of the rear end;
* rear rig-connection brackets (10 mm plates with a foot flange) outside the rail webs, their
  feet tied by the rig adapter's tube;
* air bellows under the rails: grounded CBUSH springs.

The rig frames (:data:`RIG`, :data:`RIG_BATTERY`: 3526 mm, five cross members, brackets at both
ends) stand on the 7-post rig's actuators instead (:func:`_actuators`), one with a battery box.

Every bolt is modelled as in the study's deck: an RBE2 spider from the node at the bolt's
centre to the ring of nodes around it (the hole rim and washer) in each ply, and a CBAR
between consecutive centres with the bolt's section (one PBAR per bolt group). Holes are not
cut: the spider's rigid patch stands for the bolt head and washer.

Coordinates: X from the front end rearwards, Y to the left, Z up; the rails' webs at
Y = +-430, the frame's mid-height at Z = 0. Everything is built on shared station lines
(:mod:`femcal.examples.mesher`), so the rails, liners, end plates and brackets are conforming
where they meet and the decks regenerate byte-identically.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field, replace

import numpy as np

from ..deck.writer import format_card
from .mesher import Mesh, stations

#: Element size (mm).
H = 25.0

# ----------------------------------------------------------------------------- dimensions


@dataclass(frozen=True)
class FrameDimensions:
    """Dimensions of the frame (mm); see the module docstring for the parts."""

    length: float = 3500.0
    half_width: float = 430.0  # rail web mid-surface to the centre line
    web: float = 255.0  # rail web height (mid-surface to mid-surface of the flanges)
    flange: float = 90.0
    liner_gap: float = 6.5  # rail web to liner web, mid-surfaces: (8 + 5) / 2
    liner_flange: float = 75.0
    liner_x: tuple[float, float] = (150.0, 3350.0)
    cross_x: tuple[float, ...] = (270.0, 1150.0, 2475.0, 2825.0)
    cross_kinds: tuple[int, ...] = (0, 1, 2, 3)  # X1-X4 kinds (see CROSS_KINDS) of each member
    rear_bracket_drop: float = 290.0  # how far the rig-connection brackets reach below
    cross_height: tuple[float, ...] = (150.0, 90.0, 120.0, 120.0)
    tube_half_width: float = 50.0  # X2, along X
    bellows_x: tuple[float, ...] = (500.0, 3050.0)
    bracket_x0: tuple[float, ...] = (3360.0,)  # rig-connection brackets, 140 mm long each
    actuators: bool = False  # the 7-post rig's actuators instead of bellows
    battery_x: tuple[float, ...] = ()  # battery box brackets on the left rail (empty: none)
    rear_tie: bool = True  # a tube between the rear brackets' feet (the rig adapter's)


#: The 7-post rig frame: 3526 mm, five cross members, rig brackets at both ends.
RIG = FrameDimensions(
    length=3526.0,
    liner_x=(150.0, 3376.0),
    cross_x=(270.0, 1000.0, 1750.0, 2475.0, 3276.0),
    cross_kinds=(0, 1, 2, 0, 3),
    cross_height=(150.0, 90.0, 120.0, 150.0, 120.0),
    bellows_x=(),
    bracket_x0=(0.0, 3386.0),
    actuators=True,
    rear_tie=False,  # the actuators hold the brackets' feet
)
#: The rig frame with the battery box hung from the left rail.
RIG_BATTERY = replace(RIG, battery_x=(1250.0, 1500.0))


#: PSHELL id -> (name, thickness mm, MAT1 id). Ids 1-8 are the study's thickness parameters.
SHELLS = {
    1: ("side rail", 8.0, 1),
    2: ("inner liner", 5.0, 2),
    3: ("cross member 4", 10.0, 9),
    4: ("cross member 1", 4.0, 3),
    5: ("cross member 1 attachment", 6.0, 4),
    6: ("cross member 3 attachment", 7.0, 8),
    7: ("cross member 3", 7.0, 7),
    8: ("cross member 2", 5.0, 5),
    9: ("cross member 4 attachment", 8.0, 9),
    10: ("rig-connection brackets", 10.0, 10),
    11: ("battery box brackets", 6.0, 10),
}
#: PSOLID id of the cast brackets, and its material.
CAST_PID, CAST_MID = 20, 6

#: MAT1 id -> (name, E MPa). Every one is a calibration parameter (the study's 13 moduli).
MATERIALS = {
    1: ("side rail", 210000.0),
    2: ("inner liner", 210000.0),
    3: ("cross member 1", 210000.0),
    4: ("cross member 1 attachment", 210000.0),
    5: ("cross member 2", 210000.0),
    6: ("cross member 2 cast bracket", 164000.0),
    7: ("cross member 3", 210000.0),
    8: ("cross member 3 attachment", 210000.0),
    9: ("cross member 4 and its attachment", 210000.0),
    10: ("rear rig-connection brackets", 210000.0),
    11: ("bolts, rail to liner", 210000.0),
    12: ("bolts, cross members", 210000.0),
    13: ("bolts, brackets", 210000.0),
}
BOLT_MATERIAL_GROUPS = {11: "rail to liner", 12: "cross members", 13: "brackets"}

#: PBAR id -> (bolt group, diameter mm, MAT1 id): the study's 9 bar areas.
BOLTS = {
    31: ("rail to liner web, left", 15.0, 11),
    32: ("rail to liner web, right", 15.0, 11),
    33: ("cross member 1 attachment", 15.0, 12),
    34: ("cross member 2 cast brackets", 20.0, 12),
    35: ("cross member 3 attachment", 15.0, 12),
    36: ("cross member 4 attachment", 15.0, 12),
    37: ("rear rig-connection brackets", 18.0, 13),
    38: ("rail to liner flanges", 15.0, 11),
    39: ("air bellows mounts", 15.0, 13),
}
#: PBAR of the tie tube between the rear brackets' feet, and its outer diameter and wall (mm).
TIE_PID, TIE_TUBE = 40, (60.0, 4.0)
RHO = 7.85e-9  # t/mm^3
NU = 0.3
BELLOWS_PID = 50
#: Air bellows rates (N/mm): K1 (X), K2 (Y), K3 (Z), no rotational stiffness.
BELLOWS_K = (6.0, 6.0, 30.0)


@dataclass
class _Frame:
    dims: FrameDimensions
    mesh: Mesh = field(default_factory=Mesh)
    rbe2: list[tuple[int, list[int]]] = field(default_factory=list)
    cbar: list[tuple[int, int, int, tuple[float, float, float]]] = field(default_factory=list)
    bush: list[tuple[int, int, int]] = field(default_factory=list)  # (pid, grid, ground)
    conm2: list[tuple[int, float, tuple[float, ...]]] = field(default_factory=list)
    inputs: list[tuple[str, int, int, int]] = field(default_factory=list)  # label, grid, dir, sign
    ground: list[int] = field(default_factory=list)
    labels: dict[str, int] = field(default_factory=dict)


# ----------------------------------------------------------------------------- geometry


def _bolt(f: _Frame, pid: int, a, na, b, nb, *more, radius: float = 32.0) -> None:
    """Bolt through the plies at points a, b (and more: point, normal pairs): a spider in
    each ply (normals na, nb, ...) and a CBAR of section ``pid`` between consecutive
    centres."""
    m = f.mesh
    plies = [(a, na), (b, nb), *zip(more[::2], more[1::2], strict=True)]
    centres = []
    for p, nrm in plies:
        g = m.find(*p)
        ring = m.near(p, radius, nrm)
        if len(ring) < 3:
            raise RuntimeError(f"bolt spider at {p} found only {len(ring)} rim nodes")
        f.rbe2.append((g, ring))
        centres.append(g)
    axis = np.subtract(b, a)
    v = (0.0, 0.0, 1.0) if abs(axis[2]) < 0.5 * np.linalg.norm(axis) else (1.0, 0.0, 0.0)
    for ga, gb in itertools.pairwise(centres):
        f.cbar.append((pid, ga, gb, v))


def _x_required(d: FrameDimensions) -> list[float]:
    req = [*d.liner_x, *_web_bolt_x(d), *_flange_bolt_x(d), *d.bellows_x]
    for i, xc in enumerate(d.cross_x):
        req += [xc + o for o in CROSS_KINDS[d.cross_kinds[i]].bolt_dx] + [xc]
    for x0 in d.bracket_x0:
        req += [x0, x0 + _BRACKET_LEN, *(x0 + b for b in _BRACKET_BOLT_DX)]
        if d.actuators or d.rear_tie:  # actuators or the tie hold the brackets' middle
            req.append(x0 + _BRACKET_LEN / 2)
    for xb in d.battery_x:
        req += [xb - 50.0, xb, xb + 25.0, xb + 50.0]
    return req


_BRACKET_LEN = 140.0
_BRACKET_BOLT_DX = (35.0, 105.0)
_REAR_BOLT_Z = (-50.0, -120.0)
_BOLT_Z = 70.0  # web bolts at Z = +-70


def _web_bolt_x(d: FrameDimensions) -> list[float]:
    """Rail-to-liner web bolts: every 400 mm along the liner, clear of the cross members."""
    xs = np.arange(d.liner_x[0] + 100.0, d.liner_x[1] - 50.0, 400.0)
    return [float(x) for x in xs if min(abs(x - c) for c in d.cross_x) > 200.0]


def _flange_bolt_x(d: FrameDimensions) -> list[float]:
    xs = [800.0, 1650.0, 2050.0, 2850.0]
    return [x for x in xs if min((abs(x - b) for b in d.bellows_x), default=1e9) > 100.0]


@dataclass(frozen=True)
class _CrossKind:
    pid: int
    plate_pid: int | None  # end plate; None: cast bracket
    height: float
    flange: float  # signed: + opens rearwards, - forwards
    plate_x: tuple[float, float]  # end plate extent about the web
    plate_z: float
    bolt_dx: tuple[float, ...]
    bolt_pid: int
    gusset: float = 0.0  # triangular gusset leg (0: none)


CROSS_KINDS = (
    _CrossKind(4, 5, 200.0, 60.0, (-60.0, 80.0), 120.0, (-35.0, 35.0), 33),
    _CrossKind(8, None, 120.0, 50.0, (-70.0, 70.0), 90.0, (-35.0, 35.0), 34),  # tube +-50
    _CrossKind(7, 6, 220.0, -70.0, (-110.0, 110.0), 130.0, (-40.0, 66.0 + 22.0), 35, 66.0),
    _CrossKind(3, 9, 160.0, -60.0, (-70.0, 60.0), 110.0, (-35.0, 35.0), 36),
)


def _rails(f: _Frame, xs: np.ndarray) -> None:
    d, m = f.dims, f.mesh
    hw, hz = d.half_width, d.web / 2
    lx = xs[(xs >= d.liner_x[0]) & (xs <= d.liner_x[1])]
    for s in (1.0, -1.0):
        # rail: web (normal -s Y, pointing inwards) and flanges
        zs = stations(-hz, hz, H, (-_BOLT_Z, _BOLT_Z, 0.0, *_REAR_BOLT_Z))
        m.patch(1, (0, s * hw, 0), (1, 0, 0), (0, 0, s), xs, zs * s)
        ys = stations(hw, hw - d.flange, H, (hw - 45.0,))
        for zf in (hz, -hz):
            m.patch(1, (0, 0, zf), (1, 0, 0), (0, s, 0), xs, ys)
        # liner nested inside
        yl = hw - d.liner_gap
        zl = hz - d.liner_gap
        zs = stations(-zl, zl, H, (-_BOLT_Z, _BOLT_Z, 0.0))
        m.patch(2, (0, s * yl, 0), (1, 0, 0), (0, 0, s), lx, zs * s)
        ys = stations(yl, yl - d.liner_flange, H, (hw - 45.0,))
        for zf in (zl, -zl):
            m.patch(2, (0, 0, zf), (1, 0, 0), (0, s, 0), lx, ys)
        pid = 31 if s > 0 else 32
        for x in _web_bolt_x(d):
            for z in (-_BOLT_Z, _BOLT_Z):
                _bolt(f, pid, (x, s * hw, z), (0, 1, 0), (x, s * yl, z), (0, 1, 0))
        for x in _flange_bolt_x(d):
            for sz in (1.0, -1.0):
                a = (x, s * (hw - 45.0), sz * hz)
                b = (x, s * (hw - 45.0), sz * zl)
                _bolt(f, 38, a, (0, 0, 1), b, (0, 0, 1))


def _cross_members(f: _Frame) -> None:
    d, m = f.dims, f.mesh
    yl = d.half_width - d.liner_gap
    for i, xc in enumerate(d.cross_x):
        name = f"X{i + 1}"
        kind = replace(CROSS_KINDS[d.cross_kinds[i]], height=d.cross_height[i])
        if kind.plate_pid is None:
            kind = replace(kind, flange=d.tube_half_width)
            _tube_on_cast_brackets(f, kind, xc, yl, name)
            continue
        t_plate = SHELLS[kind.plate_pid][1]
        y_ep = yl - (5.0 + t_plate) / 2
        h2 = kind.height / 2
        x_fl = xc + kind.flange
        gx = [xc + kind.gusset * k / 3 for k in range(1, 4)] if kind.gusset else []
        px = stations(xc + kind.plate_x[0], xc + kind.plate_x[1], H,
                      (xc, x_fl, *[xc + o for o in kind.bolt_dx], *gx))  # fmt: skip
        pz = stations(-kind.plate_z, kind.plate_z, H, (-h2, h2, -_BOLT_Z, _BOLT_Z, 0.0))
        gy = [y_ep - kind.gusset * k / 3 for k in range(1, 4)] if kind.gusset else []
        ys = stations(-y_ep, y_ep, H, (0.0, *gy, *[-g for g in gy]))
        # web (plane X = xc), flanges (Z = +-h2) between the end plates
        zs = pz[(pz >= -h2 - 0.01) & (pz <= h2 + 0.01)]
        m.patch(kind.pid, (xc, 0, 0), (0, 1, 0), (0, 0, 1), ys, zs)
        fx = px[(px >= min(xc, x_fl) - 0.01) & (px <= max(xc, x_fl) + 0.01)]
        for zf in (h2, -h2):
            m.patch(kind.pid, (0, 0, zf), (1, 0, 0), (0, 1, 0), fx, ys)
        for s in (1.0, -1.0):
            m.patch(kind.plate_pid, (0, s * y_ep, 0), (1, 0, 0), (0, 0, s), px, pz * s)
            if kind.gusset:
                sx = 1.0 if kind.flange < 0 else -1.0  # behind the web, away from its flanges
                m.triangle_patch(kind.plate_pid, (xc, s * y_ep, 0.0), (sx, 0, 0), (0, -s, 0),
                                 3, kind.gusset, kind.gusset)  # fmt: skip
            for dx in kind.bolt_dx:
                for z in (-_BOLT_Z, _BOLT_Z):
                    a = (xc + dx, s * y_ep, z)
                    _bolt(f, kind.bolt_pid, a, (0, 1, 0), (xc + dx, s * yl, z), (0, 1, 0),
                          (xc + dx, s * d.half_width, z), (0, 1, 0))  # fmt: skip
        f.labels[name] = m.find(xc, 0.0, h2)


def _tube_on_cast_brackets(f: _Frame, kind: _CrossKind, xc: float, yl: float, name: str) -> None:
    m = f.mesh
    hx, h2 = kind.flange, kind.height / 2
    face = yl - 2.5  # cast bracket against the liner web
    inner = face - 40.0
    bx = stations(xc + kind.plate_x[0], xc + kind.plate_x[1], H,
                  (xc - hx, xc + hx, xc, *[xc + o for o in kind.bolt_dx]))  # fmt: skip
    bz = stations(-kind.plate_z, kind.plate_z, H, (-h2, h2, -_BOLT_Z, _BOLT_Z, 0.0))
    tx = bx[(bx >= xc - hx - 0.01) & (bx <= xc + hx + 0.01)]
    tz = bz[(bz >= -h2 - 0.01) & (bz <= h2 + 0.01)]
    ys = stations(-inner, inner, H, (0.0,))
    for zf in (h2, -h2):  # top and bottom walls
        m.patch(kind.pid, (0, 0, zf), (1, 0, 0), (0, 1, 0), tx, ys)
    for xw in (xc - hx, xc + hx):  # front and rear walls
        m.patch(kind.pid, (xw, 0, 0), (0, 1, 0), (0, 0, 1), ys, tz)
    for s in (1.0, -1.0):
        yb = stations(inner, face, 14.0)
        m.block(CAST_PID, bx, np.sort(s * yb), bz)
        for dx in kind.bolt_dx:
            for z in (-_BOLT_Z, _BOLT_Z):
                a = (xc + dx, s * face, z)
                _bolt(f, kind.bolt_pid, a, (0, 1, 0), (xc + dx, s * yl, z), (0, 1, 0),
                      (xc + dx, s * f.dims.half_width, z), (0, 1, 0))  # fmt: skip
    f.labels[name] = m.find(xc, 0.0, h2)


def _rig_brackets(f: _Frame, xs: np.ndarray) -> None:
    """Rig-connection brackets outside the rail webs: a plate reaching below the rail with a
    foot flange, bolted to the web with four bolts."""
    d, m = f.dims, f.mesh
    hz = d.web / 2
    t = SHELLS[10][1]
    bottom = -hz - d.rear_bracket_drop
    bz = stations(bottom, -20.0, H, (*_REAR_BOLT_Z, -hz))
    yb = d.half_width + (8.0 + t) / 2
    foot = stations(yb, yb + 80.0, H)
    for x0 in d.bracket_x0:
        bx = xs[(xs >= x0 - 0.01) & (xs <= x0 + _BRACKET_LEN + 0.01)]
        for s in (1.0, -1.0):
            m.patch(10, (0, s * yb, 0), (1, 0, 0), (0, 0, s), bx, bz * s)
            m.patch(10, (0, 0, bottom), (1, 0, 0), (0, s, 0), bx, foot)
            for x in (x0 + dx for dx in _BRACKET_BOLT_DX):
                for z in _REAR_BOLT_Z:
                    _bolt(f, 37, (x, s * yb, z), (0, 1, 0), (x, s * d.half_width, z), (0, 1, 0))
        if d.rear_tie and x0 == d.bracket_x0[-1]:
            yf = float(foot[len(foot) // 2])
            ends = []
            for s in (1.0, -1.0):
                centre = (x0 + _BRACKET_LEN / 2, s * yf, bottom)
                ends.append(m.find(*centre))
                f.rbe2.append((ends[-1], m.near(centre, 45.0, (0, 0, 1))))
            f.cbar.append((TIE_PID, ends[0], ends[1], (0.0, 0.0, 1.0)))


def _bellows(f: _Frame) -> None:
    d, m = f.dims, f.mesh
    z0 = -d.web / 2
    for s in (1.0, -1.0):
        for x in d.bellows_x:
            top = (x, s * (d.half_width - 45.0), z0)
            centre = m.find(*top)
            ring = m.near(top, 32.0, (0, 0, 1))
            f.rbe2.append((centre, ring))
            mount = m.node(top[0], top[1], z0 - 40.0)
            f.cbar.append((39, centre, mount, (1.0, 0.0, 0.0)))
            ground = m.node(top[0], top[1], z0 - 240.0)
            f.bush.append((BELLOWS_PID, mount, ground))
            f.ground.append(ground)


#: PBUSH ids of the actuators by direction (1 = X, 2 = Y, 3 = Z), and their axial rate: the
#: oil column of a displacement-controlled actuator (N/mm); swivels at both ends carry nothing
#: else.
ACTUATOR_PIDS = {1: 51, 2: 52, 3: 53}
ACTUATOR_K = 5.0e4
ACTUATOR_LENGTH = 500.0


def _actuator(f: _Frame, label: str, centre, normal, radius: float, comp: int, sign: int) -> None:
    """An actuator pushing the frame along ``sign`` times basic axis ``comp`` at ``centre``:
    an RBE2 from an attachment node 50 mm out to the frame nodes within ``radius`` in the
    plane normal to ``normal`` (the centre node too), and a grounded CBUSH along the axis."""
    m = f.mesh
    ring = sorted([m.find(*centre), *m.near(centre, radius, normal)])
    if len(ring) < 4:
        raise RuntimeError(f"actuator {label} at {centre} found only {len(ring)} frame nodes")
    axis = np.zeros(3)
    axis[comp - 1] = float(sign)
    attach = m.node(*(np.asarray(centre) - 50.0 * axis))
    ground = m.node(*(np.asarray(centre) - (50.0 + ACTUATOR_LENGTH) * axis))
    f.rbe2.append((attach, ring))
    f.bush.append((ACTUATOR_PIDS[comp], attach, ground))
    f.ground.append(ground)
    f.inputs.append((label, attach, comp, sign))


def _actuators(f: _Frame) -> None:
    """The 7 actuators: 4 vertical (+Z) under the rig brackets' feet, 2 lateral (+Y) on the
    right-hand brackets, 1 longitudinal (-X) at the rear end of the left rail."""
    d = f.dims
    yb = d.half_width + (8.0 + SHELLS[10][1]) / 2
    bottom = -d.web / 2 - d.rear_bracket_drop
    ends = ((d.bracket_x0[0], "front"), (d.bracket_x0[-1], "rear"))
    mid = _BRACKET_LEN / 2
    foot = stations(yb, yb + 80.0, H)
    yf = float(foot[len(foot) // 2])
    for x0, end in ends:
        for s, side in ((1.0, "left"), (-1.0, "right")):
            _actuator(f, f"V_{end}_{side}", (x0 + mid, s * yf, bottom), (0, 0, 1), 45.0, 3, 1)
    bz = stations(bottom, -20.0, H, (*_REAR_BOLT_Z, -d.web / 2))
    zl = float(bz[np.argmin(np.abs(bz - (bottom - 20.0) / 2))])
    for x0, end in ends:
        _actuator(f, f"L_{end}", (x0 + mid, -yb, zl), (0, 1, 0), 45.0, 2, 1)
    _actuator(f, "X_rear", (d.length, d.half_width, 0.0), (1, 0, 0), 60.0, 1, -1)


#: Battery box: mass (t), its centre of gravity from the left rail web (Y, mm) and height
#: (Z, mm), size (mm) for its inertia, and the PSHELL of its two L brackets.
BATTERY_MASS = 0.12
BATTERY_CG = (330.0, -180.0)
BATTERY_SIZE = (600.0, 500.0, 350.0)
BATTERY_PID = 11


def _battery(f: _Frame, xs: np.ndarray) -> None:
    """Battery box hung outside the left rail: two brackets bolted to the web (a plate on the
    web, a bottom arm and an upright web plate reaching 400 mm out), the box a rigid body (an
    RBE2 from its centre of gravity to the brackets' outer edges) with a CONM2."""
    d, m = f.dims, f.mesh
    hz = d.web / 2
    yb = d.half_width + (8.0 + SHELLS[BATTERY_PID][1]) / 2
    low = -hz - 150.0
    arm = stations(yb, yb + 400.0, H)
    bz = stations(low, -20.0, H, (*_REAR_BOLT_Z, -hz))
    ends = []
    for xb in d.battery_x:
        bx = xs[(xs >= xb - 50.01) & (xs <= xb + 50.01)]
        m.patch(BATTERY_PID, (0, yb, 0), (1, 0, 0), (0, 0, 1), bx, bz)  # on the rail web
        m.patch(BATTERY_PID, (0, 0, low), (1, 0, 0), (0, 1, 0), bx, arm)  # bottom arm
        m.patch(BATTERY_PID, (xb, 0, 0), (0, 1, 0), (0, 0, 1), arm, bz)  # upright web
        for z in _REAR_BOLT_Z:
            _bolt(f, 37, (xb + 25.0, yb, z), (0, 1, 0), (xb + 25.0, d.half_width, z), (0, 1, 0))
        ends += [m.find(x, arm[-1], low) for x in bx if abs(x - xb) > 0.01]
        ends += [m.find(xb, arm[-1], z) for z in bz]
    cg = m.node(float(np.mean(d.battery_x)), d.half_width + BATTERY_CG[0], BATTERY_CG[1])
    f.rbe2.append((cg, sorted(ends)))
    a, b, c = BATTERY_SIZE
    mb = BATTERY_MASS
    inertia = (mb * (b * b + c * c) / 12, 0.0, mb * (a * a + c * c) / 12, 0.0, 0.0,
               mb * (a * a + b * b) / 12)  # fmt: skip
    f.conm2.append((cg, mb, tuple(round(v, 1) for v in inertia)))
    f.labels["battery"] = cg


def build_frame(dims: FrameDimensions) -> _Frame:
    """A frame of the given dimensions: on air bellows (hammer test) or on the rig's
    actuators, with the battery box if ``dims.battery_x`` places it."""
    d = dims
    f = _Frame(d)
    xs = stations(0.0, d.length, H, tuple(_x_required(d)))
    _rails(f, xs)
    _cross_members(f)
    _rig_brackets(f, xs)
    if d.battery_x:
        _battery(f, xs)
    if d.bellows_x:
        _bellows(f)
    if d.actuators:
        _actuators(f)
    return f


def build_hammer_frame(dims: FrameDimensions | None = None) -> _Frame:
    """The hammer-test frame on air bellows."""
    return build_frame(dims or FrameDimensions())


# ----------------------------------------------------------------------------- deck text


def deck_lines(f: _Frame, title: str) -> list[str]:
    """The frame as NASTRAN SOL 103 text (small field where exact)."""
    out = [
        f"$ {title}",
        "$ written by femcal.examples.truck_frame: units mm, tonne, s, N, MPa",
        "SOL 103",
        "CEND",
        f"TITLE = {title}",
        "ECHO = NONE",
        "SUBCASE 1",
        "  METHOD = 1",
        "  SPC = 1",
        "  DISPLACEMENT(PLOT) = ALL",
        "BEGIN BULK",
        "PARAM   AUTOSPC YES",
        "PARAM   GRDPNT  0",
        "EIGRL   1               150.",
    ]

    def card(name: str, *vals) -> None:
        out.extend(format_card(name, list(vals), field_format="small"))

    out.append("$ materials: every MAT1 is a calibration parameter (E)")
    for mid, (name, E) in MATERIALS.items():
        out.append(f"$ MAT1 {mid}: {name}")
        card("MAT1", mid, E, None, NU, RHO)
    out.append("$ shell properties")
    used = {e[0] for e in f.mesh.quads} | {e[0] for e in f.mesh.trias}
    for pid, (name, t, mid) in SHELLS.items():
        if pid not in used:
            continue
        out.append(f"$ PSHELL {pid}: {name}, {t:g} mm")
        card("PSHELL", pid, mid, t, mid, None, mid)
    card("PSOLID", CAST_PID, CAST_MID)
    out.append("$ bolts: one PBAR per bolt group, solid circular sections")
    for pid, (name, dia, mid) in BOLTS.items():
        r = dia / 2
        area = round(np.pi * r * r, 2)
        inertia = round(np.pi * r**4 / 4, 1)
        out.append(f"$ PBAR {pid}: {name}, M{dia:g}")
        card("PBAR", pid, mid, area, inertia, inertia, 2.0 * inertia)
    if any(b[0] == TIE_PID for b in f.cbar):
        do, wall = TIE_TUBE
        di = do - 2 * wall
        area = round(np.pi * (do**2 - di**2) / 4, 2)
        inertia = round(np.pi * (do**4 - di**4) / 64, 1)
        out.append(f"$ PBAR {TIE_PID}: tie tube between the rear brackets, {do:g} x {wall:g} mm")
        card("PBAR", TIE_PID, 10, area, inertia, inertia, 2.0 * inertia)
    bush_pids = {b[0] for b in f.bush}
    if BELLOWS_PID in bush_pids:
        out.append("$ air bellows")
        card("PBUSH", BELLOWS_PID, "K", *BELLOWS_K, 0.0, 0.0, 0.0)
    for comp, pid in ACTUATOR_PIDS.items():
        if pid in bush_pids:
            out.append(f"$ actuators along {'XYZ'[comp - 1]}: oil column only (swivel ends)")
            k = [0.0] * 6
            k[comp - 1] = ACTUATOR_K
            card("PBUSH", pid, "K", *k)
    out.append("$ grids")
    for gid, (x, y, z) in enumerate(f.mesh.xyz, start=1):
        card("GRID", gid, None, x, y, z)
    eid = 0
    out.append("$ shells")
    for q in f.mesh.quads:
        eid += 1
        card("CQUAD4", eid, *q)
    for t in f.mesh.trias:
        eid += 1
        card("CTRIA3", eid, *t)
    out.append("$ cast brackets")
    for h in f.mesh.hexas:
        eid += 1
        card("CHEXA", eid, *h)
    out.append("$ bolts")
    for pid, ga, gb, v in f.cbar:
        eid += 1
        card("CBAR", eid, pid, ga, gb, *v)
    for pid, ga, gg in f.bush:
        eid += 1
        card("CBUSH", eid, pid, ga, gg, None, None, None, 0)
    for g, mass, inertia in f.conm2:
        eid += 1
        card("CONM2", eid, g, 0, mass, 0.0, 0.0, 0.0, None, *inertia)
    out.append("$ bolt spiders")
    for g, ring in f.rbe2:
        eid += 1
        card("RBE2", eid, g, 123456, *ring)
    out.append("$ grounds of the springs")
    for g in f.ground:
        card("SPC1", 1, 123456, g)
    out.append("ENDDATA")
    return out


# ----------------------------------------------------------------------------- data files


#: The study's parameters in its order: (card, id, field, description, relative bound).
def parameters() -> list[dict]:
    """The 30 calibration parameters: 8 PSHELL T, 9 PBAR A, 13 MAT1 E, with the study's
    bounds (thicknesses and member moduli +-20 %, bolt moduli +-40 %, bar areas +-20 %)."""
    out = []
    for pid in range(1, 9):
        name, t, _ = SHELLS[pid]
        out.append(("PSHELL", pid, "T", f"{name} thickness (mm)", t, 0.2))
    for pid, (name, dia, _) in BOLTS.items():
        out.append(("PBAR", pid, "A", f"bolt area, {name} (mm^2)", round(np.pi * dia**2 / 4, 2),
                    0.2))  # fmt: skip
    for mid, (name, E) in MATERIALS.items():
        rel = 0.4 if mid in BOLT_MATERIAL_GROUPS else 0.2
        out.append(("MAT1", mid, "E", f"Young's modulus, {name} (MPa)", E, rel))
    return [
        {"name": f"p{i}", "description": d, "card": c, "id": k, "field": fld, "nominal": v,
         "lower": round(v * (1 - r), 6), "upper": round(v * (1 + r), 6)}
        for i, (c, k, fld, d, v, r) in enumerate(out, start=1)
    ]  # fmt: skip


def params_toml(params: list[dict]) -> list[str]:
    """TOML text of the parameter table (one [[parameter]] table per parameter)."""
    lines = [
        "# Calibration parameters of the hammer frame: P = P0 (1 + p), within [lower, upper].",
        "# Written by femcal.examples.truck_frame; the study's 30 parameters (see METHOD.md).",
    ]
    for p in params:
        lines += ["", "[[parameter]]"]
        for k in ("name", "description", "card", "id", "field", "nominal", "lower", "upper"):
            v = p[k]
            lines.append(f'{k} = "{v}"' if isinstance(v, str) else f"{k} = {v!r}")
    return lines


def _nearest_node(f: _Frame, x: float, y: float, z: float) -> int:
    X = np.asarray(f.mesh.xyz)
    return int(np.argmin(np.linalg.norm(X - (x, y, z), axis=1))) + 1


def sensors(f: _Frame) -> list[tuple[str, int]]:
    """The 24 accelerometer positions (label, GRID): ten on the top of each rail's web, one
    at mid-span of each cross member's top."""
    d = f.dims
    out = []
    xs = np.linspace(60.0, d.length - 60.0, 10)
    for s, side in ((1.0, "L"), (-1.0, "R")):
        for i, x in enumerate(xs, start=1):
            out.append((f"{side}{i:02d}", _nearest_node(f, x, s * d.half_width, d.web / 2)))
    for i in range(4):
        out.append((f"X{i + 1}", f.labels[f"X{i + 1}"]))
    return out


def hammer_inputs(f: _Frame) -> list[tuple[str, int, int]]:
    """The two hammer impacts (label, GRID, direction 2 = Y or 3 = Z)."""
    d = f.dims
    # left rail web: 1500 mm is clear of the nodes of the lateral bending modes, so the lateral
    # impact excites each of them
    g_y = _nearest_node(f, 1500.0, d.half_width, 0.0)
    g_z = _nearest_node(f, 700.0, -(d.half_width - 45.0), d.web / 2)  # right rail top flange
    return [("hammer_Y", g_y, 2), ("hammer_Z", g_z, 3)]


def rig_sensors(f: _Frame) -> list[tuple[str, int, str]]:
    """One accelerometer near each actuator, measuring along its stroke (label, GRID,
    signed direction code): on the rig bracket's plate about 100 mm from the attachment, or
    on the rail web 100 mm ahead of the longitudinal one; with the battery box, a triaxial
    one at its centre of gravity (directions ``123``)."""
    d = f.dims
    yb = d.half_width + (8.0 + SHELLS[10][1]) / 2
    X = np.asarray(f.mesh.xyz)
    out = []
    for label, g, comp, sign in f.inputs:
        p = X[g - 1]
        if comp == 3:
            target = (p[0], np.sign(p[1]) * yb, p[2] + 150.0)
        elif comp == 2:
            target = (p[0], -yb, p[2] + 100.0)
        else:
            target = (d.length - 100.0, d.half_width, 0.0)
        out.append((f"S_{label}", _nearest_node(f, *target), str(comp * sign)))
    if "battery" in f.labels:
        out.append(("S_battery", f.labels["battery"], "123"))
    return out


VARIANTS = {
    "hammer": ("hammer_frame", "truck ladder frame on air bellows (hammer test)"),
    "rig": ("rig_frame", "truck ladder frame on the 7-post rig"),
    "rig-battery": ("rig_frame_battery", "truck ladder frame on the 7-post rig, battery box"),
}


#: The rig's actuators: stroke +/- 25 mm, 1000 mm/s, 100 000 mm/s^2 (about 10 g), the size
#: of a frame rig's servo-hydraulic actuators.
RIG_LIMITS = (25, 1000, 100000)


def write_frame(variant: str, out_dir) -> list:
    """Write a variant's deck and data files into ``out_dir`` (each atomically); returns
    the paths.

    hammer: ``hammer_frame.bdf``, ``.params.toml`` (the 30 calibration parameters),
    ``.sensors.csv`` (24 positions x 3 directions) and ``.inputs.csv`` (2 hammer impacts);
    rig, rig-battery: ``rig_frame[_battery].bdf``, ``.sensors.csv`` (7 accelerometers near
    the actuators along their strokes, plus a triaxial one on the battery box) and
    ``.inputs.csv`` (the 7 actuators with their limits, :data:`RIG_LIMITS`). A direction is
    the basic axis 1, 2, 3, negative for the minus direction.
    """
    from pathlib import Path

    from ..atomic import write_lines

    if variant not in VARIANTS:
        raise ValueError(f"unknown truck-frame variant {variant!r}; expected one of "
                         f"{', '.join(VARIANTS)}")  # fmt: skip
    stem, title = VARIANTS[variant]
    out_dir = Path(out_dir)
    dims = {"hammer": FrameDimensions(), "rig": RIG, "rig-battery": RIG_BATTERY}[variant]
    f = build_frame(dims)
    X = f.mesh.xyz
    paths = [write_lines(out_dir / f"{stem}.bdf", deck_lines(f, title))]
    if variant == "hammer":
        paths.append(write_lines(out_dir / f"{stem}.params.toml", params_toml(parameters())))
        where = [(lab, g, "123") for lab, g in sensors(f)]
        inputs = hammer_inputs(f)
    else:
        where = rig_sensors(f)
        inputs = [(lab, g, comp * sign) for lab, g, comp, sign in f.inputs]
    rows = ["label,grid,x,y,z,directions"]
    rows += [f"{lab},{g},{X[g - 1][0]:g},{X[g - 1][1]:g},{X[g - 1][2]:g},{dirs}"
             for lab, g, dirs in where]  # fmt: skip
    paths.append(write_lines(out_dir / f"{stem}.sensors.csv", rows))
    head, limits = "label,grid,x,y,z,direction", ""
    if variant != "hammer":  # the actuators' stroke (+/- mm), velocity and acceleration
        head, limits = head + ",stroke,velocity,acceleration", f",{','.join(map(str, RIG_LIMITS))}"
    rows = [head]
    rows += [f"{lab},{g},{X[g - 1][0]:g},{X[g - 1][1]:g},{X[g - 1][2]:g},{c}{limits}"
             for lab, g, c in inputs]  # fmt: skip
    paths.append(write_lines(out_dir / f"{stem}.inputs.csv", rows))
    return paths


def write_hammer_frame(out_dir) -> list:
    """The hammer variant's files (see :func:`write_frame`)."""
    return write_frame("hammer", out_dir)
