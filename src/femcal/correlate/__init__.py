"""Correlation of test and FE modes: MAC, pairing by MAC and frequency, frequency
differences, SEREP pseudo-orthogonality, modal scale factors."""

from .shapes import (
    Pair,
    frequency_difference,
    in_scale_of,
    mac,
    modal_scale_factor,
    pair_modes,
    pseudo_orthogonality,
    real_shapes,
    serep_mass,
)

__all__ = [
    "Pair",
    "frequency_difference",
    "in_scale_of",
    "mac",
    "modal_scale_factor",
    "pair_modes",
    "pseudo_orthogonality",
    "real_shapes",
    "serep_mass",
]
