"""Units of time-history channels: how many SI units one of them is, so that a lab's drive in
inches or a target in g meets a model in mm and N.

Understood: lengths (m, cm, mm, um/µm, in, ft), forces (N, kN, mN, lbf), velocities (a length
per s) and accelerations (a length per s^2, written ``mm/s^2``, ``mm/s2``, ``mm/s²`` or
``mm/(s^2)``, and ``g``, standard gravity). A blank unit is taken to be the model's own.
"""

from __future__ import annotations

from ..errors import TimeDataError

_LENGTH = {"m": 1.0, "cm": 1e-2, "mm": 1e-3, "um": 1e-6, "µm": 1e-6, "in": 0.0254,
           "ft": 0.3048}  # fmt: skip
_FORCE = {"N": 1.0, "kN": 1e3, "mN": 1e-3, "lbf": 4.4482216152605}
_G = 9.80665  # m/s^2, standard gravity


def si_unit(unit: str) -> tuple[str, float] | None:
    """(kind, SI value of one unit) of ``unit``: kind ``length``, ``force``, ``velocity`` or
    ``acceleration``; None for a unit not understood."""
    u = unit.strip().replace(" ", "").replace("²", "^2").replace("(", "").replace(")", "")
    if u.lower() == "g":
        return "acceleration", _G
    if u in _LENGTH:
        return "length", _LENGTH[u]
    if u in _FORCE:
        return "force", _FORCE[u]
    head, sep, tail = u.partition("/")
    if sep and head in _LENGTH:
        if tail == "s":
            return "velocity", _LENGTH[head]
        if tail in ("s^2", "s2", "s/s"):
            return "acceleration", _LENGTH[head]
    return None


def unit_factor(unit: str, to: str, what: str) -> float:
    """The factor that turns values in ``unit`` into values in ``to`` (1 when either is
    blank: a blank unit is the model's own).

    Raises
    ------
    TimeDataError
        Naming ``what`` (a channel, a file): a unit not understood, or units of different
        kinds (a force where a length is expected).
    """
    if not unit.strip() or not to.strip() or unit.strip() == to.strip():
        return 1.0
    have, want = si_unit(unit), si_unit(to)
    if have is None or want is None:
        bad = unit if have is None else to
        raise TimeDataError(f"{what}: unit {bad!r} is not one femcal converts (lengths m, cm, "
                            "mm, um, in, ft; forces N, kN, mN, lbf; a length per s or per "
                            f"s^2; g); expected {to!r} or a unit convertible to it")
    if have[0] != want[0]:
        raise TimeDataError(f"{what}: in {unit!r}, a {have[0]}; expected a {want[0]} "
                            f"({to!r})")  # fmt: skip
    return have[1] / want[1]
