"""Correlation of test and FE modes: MAC, pairing by MAC and frequency, frequency
differences, SEREP pseudo-orthogonality, modal scale factors, the rigid-body share of a shape."""

from .shapes import (
    Pair,
    comac,
    frequency_difference,
    in_scale_of,
    mac,
    mac_text,
    modal_scale_factor,
    pair_modes,
    pseudo_orthogonality,
    real_shapes,
    rigid_share,
    serep_mass,
    sign_agreement,
)

__all__ = [
    "Pair",
    "comac",
    "frequency_difference",
    "in_scale_of",
    "mac",
    "mac_text",
    "modal_scale_factor",
    "pair_modes",
    "pseudo_orthogonality",
    "real_shapes",
    "rigid_share",
    "serep_mass",
    "sign_agreement",
]
