"""Time histories: sampled channels of a test (rig drives, displacements, forces,
accelerations), as the RPC III files of a durability lab hold them."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import TimeDataError


@dataclass(frozen=True)
class TimeData:
    """Channels sampled together at a fixed step.

    Attributes
    ----------
    dt : sampling step (s).
    values : (n_channels, n_samples) samples in each channel's units.
    names : (n_channels,) channel names (RPC III DESC.CHAN_n).
    units : (n_channels,) channel units as written (``"mm"``, ``"N"``, ``"g"``), ``""`` for
        none.
    header : the file's other keywords and values, as read (for a file femcal read), so that
        a lab's bookkeeping survives a round trip.
    """

    dt: float
    values: np.ndarray
    names: tuple[str, ...]
    units: tuple[str, ...]
    header: dict[str, str] = field(default_factory=dict)

    def __post_init__(self) -> None:
        v = self.values
        if v.ndim != 2:
            raise TimeDataError(f"time data: values of shape {v.shape}; expected (channels, "
                                "samples)")  # fmt: skip
        if not (np.isfinite(self.dt) and self.dt > 0):
            raise TimeDataError(f"time data: dt = {self.dt}; expected a step > 0 s")
        if len(self.names) != v.shape[0] or len(self.units) != v.shape[0]:
            raise TimeDataError(f"time data: {v.shape[0]} channels, {len(self.names)} names "
                                f"and {len(self.units)} units; expected one of each per "
                                "channel")  # fmt: skip

    @property
    def n_channels(self) -> int:
        return int(self.values.shape[0])

    @property
    def n_samples(self) -> int:
        return int(self.values.shape[1])

    @property
    def time(self) -> np.ndarray:
        """(n_samples,) sample times from 0 (s)."""
        return np.arange(self.n_samples) * self.dt

    def channel(self, name: str) -> int:
        """Index of the channel called ``name``.

        Raises
        ------
        TimeDataError
            Naming the channels there are, when none is called so, or the channels that
            are, when several are (which one is meant cannot be guessed).
        """
        found = [k for k, n in enumerate(self.names) if n == name]
        if not found:
            raise TimeDataError(f"no channel {name!r}; the channels are "
                                f"{', '.join(map(repr, self.names))}")  # fmt: skip
        if len(found) > 1:
            raise TimeDataError(f"{len(found)} channels are called {name!r} (channels "
                                f"{', '.join(str(k + 1) for k in found)}); expected one "
                                "channel of each name")  # fmt: skip
        return found[0]
