"""How a measurement's FRFs are laid out, and the one orientation identification works in.

A roving-hammer test hits the structure at many points and measures at one (or a few): its
FRFs arrive as few outputs x many inputs, the response channels being the references. A
roving-accelerometer (or shaker) test measures many outputs for few inputs, the inputs
being the references. A lab may also hand either over transposed (by reciprocity,
``H_oi = H_io`` for a structure without gyroscopic or active parts).

Identification sees one orientation only: the FRF matrix with the *roving* side (the larger
one) as its rows and the *references* (the smaller side) as its columns, transposing the data
when they have more inputs than outputs. The state-space model ``H = C (sI - A)^-1 B + D``
of the transposed data is the data's own transposed, ``(A^T, C^T, B^T, D^T)``: the same
poles, whichever way the file was written, and the mode shapes at the roving points (an
output shape ``C v`` in one orientation is the input participation in the other). So an
``N x 1`` set and its ``1 x N`` transpose give the same poles to round-off, and each mode's
shape at all N points.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..testdata.data import Channel


@dataclass(frozen=True)
class Layout:
    """The layout of an FRF set and its identification orientation.

    Attributes
    ----------
    transposed : True when the data have more inputs than outputs (a roving-hammer set as
        measured): identification works on H transposed.
    roving : the channels at which mode shapes are given (the data's outputs, or its inputs
        when transposed), (n_roving,).
    references : the other side (the data's inputs, or its outputs when transposed).
    """

    transposed: bool
    roving: tuple[Channel, ...]
    references: tuple[Channel, ...]

    @classmethod
    def of(cls, outputs: tuple[Channel, ...], inputs: tuple[Channel, ...]) -> Layout:
        """The layout of a set with these outputs and inputs: transposed when there are more
        inputs than outputs."""
        if len(inputs) > len(outputs):
            return cls(True, tuple(inputs), tuple(outputs))
        return cls(False, tuple(outputs), tuple(inputs))

    def canonical(self, H: np.ndarray) -> np.ndarray:
        """H (outputs, inputs, ...) as identification sees it: (roving, references, ...)."""
        return np.swapaxes(H, 0, 1) if self.transposed else H

    @property
    def kind(self) -> str:
        """What the layout is in a test engineer's words."""
        if len(self.roving) == 1 and len(self.references) == 1:
            return "a single FRF"
        if self.transposed:
            return ("roving hammer" if len(self.references) == 1
                    else "roving excitation with several responses")  # fmt: skip
        if len(self.references) == 1:
            return "fixed excitation, roving or many responses"
        return "multiple references (MIMO)"

    def describe(self) -> str:
        """One line: the layout, which side is the reference, and where the shapes are."""
        n_r, n_ref = len(self.roving), len(self.references)
        refs = ", ".join(c.label for c in self.references[:4])
        if n_ref > 4:
            refs += f" and {n_ref - 4} more"
        if self.transposed:
            return (f"{self.kind}: {n_ref} response channel{'s' if n_ref > 1 else ''} "
                    f"({refs}) as reference, {n_r} excitation points; mode shapes at the "
                    "excitation points (by reciprocity)")  # fmt: skip
        return (f"{self.kind}: {n_ref} input{'s' if n_ref > 1 else ''} ({refs}) as "
                f"reference, {n_r} response channels; mode shapes at the response channels")
