"""What each element type references: the property cards it may name (None: it has no
property; its values are on the element card). The model builders, from a deck and in code,
check an element's property against these."""

from __future__ import annotations

_SHELL_PROPS = ("PSHELL", "PCOMP", "PCOMPG")
#: Solid elements: their meshes make a three-dimensional matrix graph.
SOLIDS = ("CHEXA", "CPENTA", "CTETRA", "CPYRAM")
#: Property cards each element may reference (None: the element has no PID).
ELEMENT_PROPERTIES: dict[str, tuple[str, ...] | None] = {
    **{e: _SHELL_PROPS for e in ("CQUAD4", "CTRIA3", "CQUAD8", "CTRIA6", "CQUADR", "CTRIAR")},
    "CSHEAR": ("PSHEAR",),
    **{e: ("PSOLID",) for e in SOLIDS},
    "CBAR": ("PBAR", "PBARL"),
    "CBEAM": ("PBEAM", "PBEAML"),
    "CROD": ("PROD",),
    "CTUBE": ("PTUBE",),
    "CBUSH": ("PBUSH",),
    "CELAS1": ("PELAS",),
    "CELAS3": ("PELAS",),
    "CMASS1": ("PMASS",),
    "CMASS3": ("PMASS",),
    **{e: None for e in ("CONROD", "CELAS2", "CELAS4", "CMASS2", "CMASS4", "CONM1", "CONM2")},
}
