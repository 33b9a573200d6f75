"""Blank-field markers shared by the deck reader and the model's tables.

A field left blank on a card, with no default, is stored as :data:`INT_BLANK` in an integer
column and as NaN (:data:`REAL_BLANK`) in a real one. The deck layer writes them; the model,
property and assembly layers read them, without knowing how a card was parsed.
"""

from __future__ import annotations

import math

#: Stored in integer columns for a blank field that has no default.
INT_BLANK = -(2**62)
#: Stored in real columns for a blank field that has no default.
REAL_BLANK = math.nan
