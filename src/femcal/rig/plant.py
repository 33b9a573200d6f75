"""The frame on a rig of displacement-driven actuators, as a modal model from drives to
measured channels.

Each actuator is an oil column (a spring element, the CBUSH of ``rig_frame.bdf``) from a
grid on the frame (the attachment, the inputs CSV's grid) to a grounded grid (one the SPC
fixes). The servo drives the grounded end: it moves ``s_j(t)`` along the actuator's
direction ``e_j``, so the frame, with the oil columns in its stiffness, is loaded by the
forces the moved ends make::

    M u'' + C u' + K u = B s,     B = -K[:, G] E

(``G`` the grounded grids' translations, ``E`` the directions in their displacement frames).
Its displacement is written as the static response to the drives plus the dynamic remainder
of the kept modes (the mode-acceleration method; Craig and Kurdila, Fundamentals of
Structural Dynamics, 2nd ed., sec. 14.5)::

    u = R s + Phi xi,      R = T K_aa^-1 T^T B,

with mass-normalised modes phi_r (circular frequencies w_r, modal damping zeta_r) kept up to
a frequency and ``beta = Phi^T B``: the modal coordinates ``q = beta s / w^2 + xi`` of
``q'' + 2 zeta w q' + w^2 q = beta . s`` give

    xi_r'' + 2 zeta_r w_r xi_r' + w_r^2 xi_r = -(beta_r . s'' + 2 zeta_r w_r beta_r . s') / w_r^2.

Below the modes, where the response is nearly static, ``xi`` is small and the static part
carries the response exactly, so that accelerations and forces there do not come from the
difference of large modal and static terms. The modes left out enter statically, and in the
forces also with their first inertia term ``-R2 s''``, ``R2 = T K_aa^-1 T^T M R - sum_r
phi_r beta_r / w_r^4`` (their ``1 / (w_r^2 - w^2)`` to second order): a frame moved
rigidly on stiff columns whose rigid-body modes lie above the kept ones still loads its
load cells with its inertia.

The measured channels are linear in xi, xi'', s and s''::

    y = Yd xi + Ya xi'' + D0 s + D2 s''

- an accelerometer along a basic axis at a grid: ``Ya = c Phi``, ``D2 = c R``;
- an actuator's force (its load cell, positive when it pushes the frame along its
  direction), the oil column's force at the grounded end: ``F_j = e_j^T (K[G_j, :] u +
  K[G_j, G_j] e_j s_j)``, so ``Yd = e^T K[G, :] Phi``, ``D0 = e^T K[G, :] R + k_j`` (the
  column's stiffness ``k_j = e^T K[G_j, G_j] e``), ``D2 = -e^T K[G, :] R2``;
- an actuator's displacement (its LVDT): ``D0 = 1``.

Its frequency response (:meth:`RigPlant.frf`) is ``(Yd - w^2 Ya) G(w) P(w) beta + D0 -
w^2 D2`` with ``G_r = 1 / (w_r^2 - w^2 + 2 i zeta_r w_r w)`` and ``P_r = (w^2 - 2 i zeta_r
w_r w) / w_r^2``, which equals the plain modal sum ``(Yd - w^2 Ya) G beta`` plus the
residual of the modes left out.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sp

from ..assembly import Matrices, Options, assemble
from ..errors import ModelError
from ..model import EigenRequest
from ..model.model import Model
from ..response.frf import channel_matrix
from ..solve.factor import NotPositiveDefinite, factorize
from ..solve.normal_modes import solve_normal_modes
from ..testdata.data import Channel
from ..testdata.points import point_label

_AXES = np.eye(3)


@dataclass(frozen=True)
class Actuator:
    """One displacement-driven actuator.

    Attributes
    ----------
    label : its name (the inputs CSV's label).
    grid : the oil column's frame end (NASTRAN id).
    ground : the oil column's grounded end, which the actuator moves (NASTRAN id).
    direction : (3,) unit vector of its stroke in the basic frame.
    stiffness : the oil column's stiffness along the stroke (force/length).
    position : (3,) the frame end's position in the basic frame.
    """

    label: str
    grid: int
    ground: int
    direction: np.ndarray
    stiffness: float
    position: np.ndarray = field(default_factory=lambda: np.zeros(3))


@dataclass(frozen=True)
class RigPlant:
    """A modal model from the actuators' displacements to the measured channels in the
    mode-acceleration form (see the module docstring).

    Attributes
    ----------
    omega : (k,) circular frequencies of the kept modes (rad/s), all > 0.
    zeta : (k,) modal damping ratios, in [0, 1).
    beta : (k, n_in) modal participation of each drive (force per length per modal mass).
    Yd, Ya : (n_out, k) output per dynamic modal displacement xi and per its acceleration.
    D0, D2 : (n_out, n_in) output per drive displacement and per drive acceleration (the
        static response).
    inputs : (n_in,) drive names (the actuators' labels); outputs : (n_out,) channel names
        (``S_V_front_left:+Z``, ``V_front_left:force``, ``V_front_left:displacement``).
    input_units : the drives' unit (length); output_units : (n_out,) each channel's unit.
    actuators : (n_in,) what drives it.
    """

    omega: np.ndarray
    zeta: np.ndarray
    beta: np.ndarray
    Yd: np.ndarray
    Ya: np.ndarray
    D0: np.ndarray
    D2: np.ndarray
    inputs: tuple[str, ...]
    outputs: tuple[str, ...]
    input_units: str
    output_units: tuple[str, ...]
    actuators: tuple[Actuator, ...] = ()

    def __post_init__(self) -> None:
        k, n_in = self.beta.shape
        n_out = len(self.outputs)
        shapes = {"omega": (self.omega.shape, (k,)), "zeta": (self.zeta.shape, (k,)),
                  "Yd": (self.Yd.shape, (n_out, k)), "Ya": (self.Ya.shape, (n_out, k)),
                  "D0": (self.D0.shape, (n_out, n_in)), "D2": (self.D2.shape, (n_out, n_in))}
        for name, (have, want) in shapes.items():
            if have != want:
                raise ValueError(f"rig plant: {name} has shape {have}; expected {want}")
        if len(self.inputs) != n_in or len(self.output_units) != n_out:
            raise ValueError("rig plant: one name per drive and one unit per output expected")
        if not (np.all(self.omega > 0) and np.all((self.zeta >= 0) & (self.zeta < 1))):
            raise ValueError("rig plant: expected frequencies > 0 and damping ratios in [0, 1)")

    @property
    def n_modes(self) -> int:
        return len(self.omega)

    def with_damping(self, zeta: float | np.ndarray) -> RigPlant:
        """The same plant with other modal damping ratios (one, or one per mode)."""
        z = np.broadcast_to(np.asarray(zeta, float), self.omega.shape).copy()
        return replace(self, zeta=z)

    def frf(self, frequency_hz: np.ndarray) -> np.ndarray:
        """Output per drive displacement (n_out, n_in, n_f) at ``frequency_hz`` (n_f,)."""
        w = 2 * np.pi * np.asarray(frequency_hz, float)
        wz = (self.zeta * self.omega)[:, None]
        G = (w**2 - 2j * wz * w) / (self.omega[:, None] ** 2 * (self.omega[:, None] ** 2
                                                                - w**2 + 2j * wz * w))
        out = np.einsum("ok,kf,ki->oif", self.Yd, G, self.beta, optimize=True)
        out -= np.einsum("ok,kf,ki->oif", self.Ya, G * w**2, self.beta, optimize=True)
        return out + self.D0[:, :, None] - self.D2[:, :, None] * w**2


def signed_axis(code: int) -> np.ndarray:
    """The basic-frame unit vector of a signed direction code 1-3 (``-1`` is -X)."""
    if not 1 <= abs(code) <= 3:
        raise ValueError(f"direction {code}: expected a translation 1-3, signed")
    return np.sign(code) * _AXES[abs(code) - 1]


def find_actuators(model: Model, points: Sequence[tuple[str, int, int]],
                   K: sp.spmatrix, fixed: np.ndarray) -> list[Actuator]:  # fmt: skip
    """The actuators of ``points`` (label, frame grid, signed direction 1-3: the inputs CSV):
    for each, the one grounded grid (all of whose translations ``fixed`` holds, the SPC'd
    g-set DOF) that the stiffness ``K`` (g-set) couples to the frame grid.

    Raises
    ------
    ModelError
        Naming the actuator: an unknown grid, a direction that is not a translation, no
        grounded grid coupled to its grid or more than one, or no stiffness along its
        stroke.
    """
    K = sp.csr_matrix(K)
    held = np.zeros(model.n_dof, bool)
    held[np.asarray(fixed, np.int64)] = True
    out = []
    for label, gid, code in points:
        where = f"actuator {label} (grid {gid}, direction {code})"
        idx = int(model.node_index(gid)[0])
        if idx < 0 or not model.is_grid[idx]:
            raise ModelError(f"{where}: no GRID {gid} in the model")
        try:
            e = signed_axis(code)
        except ValueError as err:
            raise ModelError(f"{where}: {err}") from None
        own = int(model.dof_start[idx]) + np.arange(6)
        cols = np.unique(K[own].indices)
        grounded = cols[held[cols]]
        nodes = np.unique(model.dof_owner(grounded)[0]) if grounded.size else np.zeros(0, int)
        nodes = [n for n in nodes if n != idx and model.is_grid[n]
                 and held[int(model.dof_start[n]) + np.arange(3)].all()]  # fmt: skip
        # several columns may share a frame grid: the actuator's is the one coupled along
        # its stroke
        along = []
        frame_e = model.cd_frames[idx].T @ e
        for n in nodes:
            gd = int(model.dof_start[n]) + np.arange(3)
            local = model.cd_frames[n].T @ e
            along.append(abs(float(frame_e @ K[own[:3]][:, gd].toarray() @ local)))
        along = np.asarray(along)
        if along.size:
            keep = along > 1e-9 * along.max()
            nodes = [n for n, k in zip(nodes, keep, strict=True) if k]
        if len(nodes) != 1:
            found = ", ".join(str(model.node_ids[n]) for n in nodes) or "none"
            raise ModelError(f"{where}: expected one oil column along the stroke from it to "
                             f"a grounded grid (a spring such as a CBUSH to a grid whose "
                             f"translations an SPC fixes); found {found}")  # fmt: skip
        g = int(nodes[0])
        gd = int(model.dof_start[g]) + np.arange(3)
        local = model.cd_frames[g].T @ e
        kgg = K[gd][:, gd].toarray()
        k = float(local @ kgg @ local)
        if not k > 0:
            raise ModelError(f"{where}: the oil column to grid {model.node_ids[g]} has no "
                             f"stiffness along the stroke ({k:g}); expected a positive one")
        out.append(Actuator(label, int(gid), int(model.node_ids[g]), e, k,
                            np.asarray(model.xyz[idx], float)))
    return out


def _drive_matrices(model: Model, actuators: Sequence[Actuator], K: sp.csr_matrix):
    """(B (n_g, n_in) loads per unit drive, F (n_in, n_g) load-cell rows on u, k (n_in,))."""
    n = model.n_dof
    B = np.zeros((n, len(actuators)))
    F = np.zeros((len(actuators), n))
    k = np.zeros(len(actuators))
    for j, a in enumerate(actuators):
        g = int(model.node_index(a.ground)[0])
        gd = int(model.dof_start[g]) + np.arange(3)
        local = model.cd_frames[g].T @ a.direction
        cols = K[:, gd] @ local  # K[:, G] e
        B[:, j] = -cols
        F[j] = cols  # K symmetric: e^T K[G, :]
        F[j, gd] = 0.0  # u is zero there; the column's own term is k s
        k[j] = a.stiffness
    return B, F, k


def rig_channel_names(actuators: Sequence[tuple[str, int, int]],
                      sensors: Sequence[tuple[str, int, int]]) -> tuple[str, ...]:
    """The rig's output channels, named from its actuators and sensors rows alone (no solve):
    each actuator's ``LABEL:displacement``, then each one's ``LABEL:force``, then each
    sensor's ``LABEL:+Z`` (its signed direction), in the rows' order, as
    :func:`build_plant`'s plant names them."""
    labels = [label for label, _, _ in actuators]
    return tuple([f"{lab}:displacement" for lab in labels] + [f"{lab}:force" for lab in labels]
                 + [f"{lab}:{point_label(g, c).split(':')[1]}" for lab, g, c in sensors])


def build_plant(model: Model, actuators: Sequence[tuple[str, int, int]],
                sensors: Sequence[tuple[str, int, int]], *, modes_to: float,
                damping: float | np.ndarray = 0.02, length_unit: str = "mm",
                force_unit: str = "N", matrices: Matrices | None = None,
                progress: Callable[[str], None] | None = None) -> RigPlant:  # fmt: skip
    """The rig plant of a model (the oil columns and their grounded grids in the deck).

    Parameters
    ----------
    model : the frame on its oil columns (grounded ends fixed by SPC).
    actuators : (label, frame grid, signed direction 1-3) rows, as the inputs CSV gives.
    sensors : (label, grid, signed direction 1-3) accelerometers, as the sensors CSV
        gives (:func:`femcal.testdata.points.read_points`).
    modes_to : modes kept up to this frequency (Hz); the others enter statically.
    damping : modal damping ratio, one or one per kept mode (see :meth:`RigPlant.
        with_damping`).
    length_unit, force_unit : the model's units, for the channel units.
    matrices : the model's g-set K and M, if already assembled (or changed: a synthetic
        test adds stiffness the deck lacks); else assembled here.

    Raises
    ------
    ModelError
        For an actuator :func:`find_actuators` refuses, an actuator or sensor given twice, a
        sensor on a grid the model lacks or along a direction that is not a translation, or
        a frame the actuators do not hold (a rigid-body mode or a singular stiffness).
    """
    say = progress or (lambda _msg: None)
    for kind, rows in (("actuator", actuators), ("sensor", sensors)):
        seen: dict[str, int] = {}
        for label, g, code in rows:
            name = label if kind == "actuator" else f"{label}:{code}"
            if name in seen:
                raise ModelError(f"{kind} {label!r} given twice (grids {seen[name]} and {g}"
                                 f"{'' if kind == 'actuator' else f', direction {code}'}); "
                                 "expected one row each: its channels are named by it")
            seen[name] = g
    for label, g, code in sensors:
        if not 1 <= abs(code) <= 3:
            raise ModelError(f"sensor {label}: direction {code}; an accelerometer measures a "
                             "translation 1-3")  # fmt: skip
        idx = int(model.node_index(g)[0])
        if idx < 0 or not model.is_grid[idx]:
            raise ModelError(f"sensor {label} (grid {g}, direction {code}): no GRID {g} in the "
                             "model; expected a grid of the frame")  # fmt: skip
    mats = matrices if matrices is not None else assemble(model, Options())
    K = sp.csr_matrix(mats.K)
    modes, red = solve_normal_modes(model, matrices=mats, progress=progress,
                                    request=EigenRequest(v2=modes_to, nd=None))  # fmt: skip
    omega = modes.radians
    if len(omega) and not (omega > 1e-6 * max(omega.max(), 1.0)).all():
        n_rigid = int((omega <= 1e-6 * max(omega.max(), 1.0)).sum())
        raise ModelError(f"the actuators do not hold the frame: {n_rigid} rigid-body mode(s); "
                         "expected the oil columns to restrain every rigid-body motion")
    acts = find_actuators(model, actuators, K, red.spc)
    B, F, k = _drive_matrices(model, acts, K)
    C = channel_matrix(model, [Channel.parse(point_label(g, c)) for _, g, c in sensors])
    say(f"static response to {len(acts)} drives")
    T = red.T
    try:
        solve, _ = factorize(red.reduce(K))
    except NotPositiveDefinite as e:
        raise ModelError(f"the stiffness of the frame on its actuators is singular ({e}); "
                         "expected the oil columns to hold it") from None  # fmt: skip
    shapes = modes.shapes
    beta = shapes.T @ B  # (k, n_in)
    R = T @ np.asarray(solve(np.asarray(T.T @ B)))
    # the left-out modes' first inertia term: sum over them of phi phi^T B / w^4
    inertia = T @ np.asarray(solve(np.asarray(T.T @ (mats.M @ R))))
    inertia -= shapes @ (beta / omega[:, None] ** 4)
    n_in, n_s, n_m = len(acts), len(sensors), len(omega)
    Yd = np.vstack([np.zeros((n_in, n_m)), F @ shapes, np.zeros((n_s, n_m))])
    Ya = np.vstack([np.zeros((2 * n_in, n_m)), np.asarray(C @ shapes)])
    D0 = np.vstack([np.eye(n_in), F @ R + np.diag(k), np.zeros((n_s, n_in))])
    D2 = np.vstack([np.zeros((n_in, n_in)), -F @ inertia, np.asarray(C @ R)])
    labels = [a.label for a in acts]  # in the rows' order
    names = rig_channel_names(actuators, sensors)
    units = [length_unit] * n_in + [force_unit] * n_in + [f"{length_unit}/s^2"] * n_s
    zeta = np.broadcast_to(np.asarray(damping, float), omega.shape).copy()
    return RigPlant(omega, zeta, beta, Yd, Ya, D0, D2, tuple(labels), names,
                    length_unit, tuple(units), tuple(acts))  # fmt: skip


def damping_from_modes(plant: RigPlant, frequency_hz: np.ndarray, damping_ratio: np.ndarray,
                       default: float, tolerance: float = 0.05) -> tuple[np.ndarray, int]:
    """Modal damping of the plant's modes from identified modes: each plant mode takes the
    damping of the identified mode nearest in frequency when it lies within ``tolerance``
    (relative), each identified mode serving at most one plant mode (the nearest); the other
    modes take ``default``.

    Returns
    -------
    (zeta (k,), how many modes took an identified damping)
    """
    f_plant = plant.omega / (2 * np.pi)
    f_id = np.asarray(frequency_hz, float)
    z_id = np.asarray(damping_ratio, float)
    zeta = np.full(plant.n_modes, float(default))
    taken = 0
    for j in np.argsort(f_id):
        if not (np.isfinite(f_id[j]) and 0 <= z_id[j] < 1):
            continue
        rel = np.abs(f_plant / f_id[j] - 1)
        r = int(np.argmin(rel)) if len(rel) else -1
        if r >= 0 and rel[r] <= tolerance and zeta[r] == default:
            zeta[r] = z_id[j]
            taken += 1
    return zeta, taken


def column_stiffness(model: Model, actuators: Sequence[tuple[str, int, int]]) -> np.ndarray:
    """Each actuator's oil-column stiffness along its stroke (n,), from the deck (see
    :func:`find_actuators`): what turns an FRF per drive displacement into one per newton
    at the actuator's frame grid, ``H / k``, as the deck with a force there computes it.

    Raises
    ------
    ModelError
        As :func:`find_actuators`.
    """
    from ..assembly.constraints import build_reduction

    K = sp.csr_matrix(assemble(model, Options()).K)
    return np.array([a.stiffness for a in
                     find_actuators(model, actuators, K, build_reduction(model).spc)])  # fmt: skip
