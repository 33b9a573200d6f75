"""What a model asks of its analysis: the PARAMs femcal honours and the eigenvalue requests.

Both are read when the model is built (from PARAM cards, case control METHOD and AUTOSPC,
EIGRL and EIGR), so the solution reads plain values and never a card. METHOD's set is looked
up when a solution asks for it (:meth:`EigenSetup.request`), so that a model whose METHOD
names no set can still be read and summarised.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..errors import ModelError


@dataclass(frozen=True)
class EigenRequest:
    """What to compute: frequencies in [v1, v2] Hz (None: unbounded), at most ``nd`` roots
    (None: every root up to v2), normalised to unit modal mass (``"MASS"``) or to a largest
    component of 1 (``"MAX"``); NASTRAN's EIGRL."""

    v1: float | None = None
    v2: float | None = None
    nd: int | None = 10
    norm: str = "MASS"


@dataclass(frozen=True)
class EigenSetup:
    """The eigenvalue requests of a model: every EIGRL / EIGR set by its SID and the set that
    case control METHOD selects.

    Attributes
    ----------
    sets : SID -> request (an EIGRL wins over an EIGR of the same SID, the first card of a
        SID over later ones).
    method : case control METHOD as written, None where there is none.
    method_at : ``"file:line"`` of METHOD, ``""`` where unknown.
    """

    sets: dict[int, EigenRequest] = field(default_factory=dict)
    method: str | None = None
    method_at: str = ""

    def request(self) -> EigenRequest:
        """The selected request.

        Raises
        ------
        ModelError
            Without METHOD, with a METHOD that is not a set id, or one no EIGRL/EIGR has.
        """
        if self.method is None:
            raise ModelError("no eigenvalue request: case control has no METHOD (SOL 103 needs an "
                             "EIGRL or EIGR set; a model built in code takes "
                             "ModelBuilder.eigen)")  # fmt: skip
        at = f"{self.method_at}: " if self.method_at else ""
        try:
            sid = int(self.method.split()[0])
        except (ValueError, IndexError):
            raise ModelError(f"{at}case control METHOD = {self.method}: expected a set "
                             "id") from None  # fmt: skip
        if sid not in self.sets:
            raise ModelError(f"{at}case control METHOD = {sid}: no EIGRL or EIGR with SID "
                             f"{sid} in the bulk data", [sid])  # fmt: skip
        return self.sets[sid]


@dataclass(frozen=True)
class Params:
    """The PARAMs that change femcal's answer, with NASTRAN's defaults, and every PARAM as read.

    Attributes
    ----------
    coupled_mass : PARAM COUPMASS > 0: coupled mass where the element has one (else lumped).
    wtmass : PARAM WTMASS, the factor on the whole mass matrix.
    k6rot : PARAM K6ROT, the shells' drilling stiffness factor.
    snorm : PARAM SNORM, degrees: the largest angle between a grid's shell normals and their
        mean for the grid to get a unique normal (<= 0: none).
    autospc : fix singular grid-point DOF before the eigen solution (case control AUTOSPC,
        else PARAM AUTOSPC; default yes).
    grdpnt : PARAM GRDPNT >= 0: the reference grid of the grid point weight summary, 0 for
        the origin; None for none.
    cards : PARAM name -> its values as written.
    """

    coupled_mass: bool = False
    wtmass: float = 1.0
    k6rot: float = 100.0
    snorm: float = 20.0
    autospc: bool = True
    grdpnt: int | None = None
    cards: dict[str, tuple] = field(default_factory=dict)
