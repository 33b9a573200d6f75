"""How well a response reproduces its target, as a durability test engineer reads it: the
error in the drive band and outside it, each channel's minimum, maximum and RMS, and the
relative fatigue damage.

- Errors come from the spectra (Parseval): in the band, the RMS of target - response over
  the band's lines as a fraction of the target's RMS over them; outside it, the RMS of the
  difference over the other lines (DC left out) as a fraction of the target's whole RMS:
  there the rig is not driven, and what remains is the target's noise floor and content
  above the band.
- Relative damage is the response's fatigue damage over the target's by Miner's sum with a
  Basquin S-N curve of slope ``m`` (``N S^m = constant``, which cancels in the ratio): the
  cycles are counted by rainflow (ASTM E1049-85, section 5.4.4, through the ``rainflow``
  package); 1 is the target's damage, above 1 the rig is harder on the part than the road.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import rainflow


def _line_weights(n: int) -> np.ndarray:
    """Each rfft line's share in the sum of squares of a record of n samples (Parseval):
    1 for DC and an even record's Nyquist line, 2 for the others."""
    w = np.full(n // 2 + 1, 2.0)
    w[0] = 1.0
    if n % 2 == 0:
        w[-1] = 1.0
    return w


def band_rms(x: np.ndarray, dt: float, band: tuple[float, float]) -> np.ndarray:
    """RMS of each row of x (rows, n) over the lines in ``band`` (Parseval)."""
    n = x.shape[1]
    f = np.fft.rfftfreq(n, dt)
    keep = (f >= band[0]) & (f <= band[1]) & (f > 0)
    X = np.fft.rfft(x, axis=1)
    return np.sqrt((np.abs(X[:, keep]) ** 2) @ _line_weights(n)[keep]) / n


@dataclass(frozen=True)
class BandErrors:
    """Errors per channel (fractions).

    Attributes
    ----------
    in_band : (n,) RMS of target - response over the band's lines / the target's there.
    out_of_band : (n,) RMS of target - response over the other lines (DC out) / the
        target's whole RMS.
    total : (n,) RMS of target - response / RMS of target.

    Each is NaN for a channel whose target has no power where it is measured (a channel
    held at zero: there is no relative error).
    """

    in_band: np.ndarray
    out_of_band: np.ndarray
    total: np.ndarray


def band_errors(target: np.ndarray, response: np.ndarray, dt: float,
                band: tuple[float, float]) -> BandErrors:  # fmt: skip
    """The errors of ``response`` against ``target`` (channels, n) sampled every ``dt`` s in
    and outside ``band`` (Hz)."""
    n = target.shape[1]
    f = np.fft.rfftfreq(n, dt)
    w = _line_weights(n)
    T = np.fft.rfft(target, axis=1)
    E = T - np.fft.rfft(response, axis=1)
    inside = (f >= band[0]) & (f <= band[1]) & (f > 0)
    outside = ~inside & (f > 0)

    def power(X: np.ndarray, lines: np.ndarray) -> np.ndarray:
        return (np.abs(X[:, lines]) ** 2) @ w[lines]

    whole = power(T, f >= 0)
    band = power(T, inside)

    def ratio(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        with np.errstate(divide="ignore", invalid="ignore"):
            return np.where(b > 0, np.sqrt(a / np.where(b > 0, b, 1.0)), np.nan)

    return BandErrors(ratio(power(E, inside), band), ratio(power(E, outside), whole),
                      ratio(power(E, f >= 0), whole))  # fmt: skip


@dataclass(frozen=True)
class ChannelStats:
    """Minimum, maximum, mean and RMS per channel (n,) of the target and of the response.

    The RMS is the whole signal's, its mean included (as a rig's statistics show it); the
    drive band starts above 0 Hz, so a target's static offset (a preload, an LVDT's mid
    stroke) is not reproduced, and the means side by side show it."""

    target_min: np.ndarray
    target_max: np.ndarray
    target_mean: np.ndarray
    target_rms: np.ndarray
    response_min: np.ndarray
    response_max: np.ndarray
    response_mean: np.ndarray
    response_rms: np.ndarray

    def of(self, which: str, k: int) -> dict[str, float]:
        """Channel ``k``'s figures of ``which`` ("target" or "response") by name."""
        return {q: float(getattr(self, f"{which}_{q}")[k]) for q in ("min", "max", "mean",
                                                                      "rms")}  # fmt: skip


def channel_stats(target: np.ndarray, response: np.ndarray) -> ChannelStats:
    """The minimum, maximum, mean and RMS of each channel of ``target`` and ``response``."""
    def figures(x: np.ndarray) -> tuple[np.ndarray, ...]:
        return x.min(axis=1), x.max(axis=1), x.mean(axis=1), np.sqrt(np.mean(x**2, axis=1))

    return ChannelStats(*figures(target), *figures(response))


def miner_sum(signal: np.ndarray, slope: float) -> float:
    """Miner's sum of a signal's rainflow cycles for an S-N curve ``N S^slope = 1``: the sum
    over cycles of count x range^slope (half cycles count one half)."""
    cycles = rainflow.count_cycles(np.asarray(signal, float))
    if not cycles:
        return 0.0
    ranges, counts = np.asarray(cycles, float).T
    return float(np.sum(counts * ranges**slope))


def relative_damage(target: np.ndarray, response: np.ndarray, slope: float) -> np.ndarray:
    """Per channel, the response's Miner sum over the target's (nan where the target has no
    cycles)."""
    if not (np.isfinite(slope) and slope > 0):
        raise ValueError(f"S-N slope {slope!r}: expected a positive number (3 to 5 for "
                         "welded steel, 5 to 12 for base metal)")  # fmt: skip
    out = np.empty(target.shape[0])
    for c in range(target.shape[0]):
        reference = miner_sum(target[c], slope)
        out[c] = miner_sum(response[c], slope) / reference if reference > 0 else np.nan
    return out
