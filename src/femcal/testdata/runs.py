"""One MIMO FRF set from several measurement runs (roving sensors, one input per run)."""

from __future__ import annotations

import numpy as np

from .data import FRFData


def assemble_runs(
    runs: list[FRFData],
    channel_maps: list[dict[str, str] | None] | None = None,
    *,
    allow_missing: bool = False,
) -> FRFData:
    """One MIMO set from several runs (e.g. roving triaxial sensors, one hammer input each).

    Parameters
    ----------
    runs : the runs, on one frequency axis and of one quantity.
    channel_maps : per run, a map from the run's channel labels (outputs and inputs) to the
        labels they stand for in the assembled set (e.g. ``{"ch3": "1005:+Y"}``); labels not
        in the map are kept. None: no renaming.
    allow_missing : leave output/input pairs no run measured as NaN instead of raising.

    Returns
    -------
    The assembled set: outputs and inputs in first-seen order; a pair measured in several
    runs is their mean.

    Raises
    ------
    ValueError
        For runs on different frequency axes or of different quantities, or (unless
        ``allow_missing``) pairs that no run measured, naming them.
    """
    if not runs:
        raise ValueError("no runs to assemble")
    maps = channel_maps if channel_maps is not None else [None] * len(runs)
    if len(maps) != len(runs):
        raise ValueError(f"{len(maps)} channel maps for {len(runs)} runs")
    f = runs[0].frequency_hz
    outs: dict[str, int] = {}
    ins: dict[str, int] = {}
    acc: dict[tuple[int, int], list[np.ndarray]] = {}
    for r, (run, cmap) in enumerate(zip(runs, maps, strict=True)):
        if len(run.frequency_hz) != len(f) or not np.allclose(run.frequency_hz, f, rtol=1e-9):
            raise ValueError(f"run {r + 1} is on another frequency axis than run 1")
        if run.quantity != runs[0].quantity:
            raise ValueError(f"run {r + 1} holds {run.quantity}, run 1 {runs[0].quantity}")
        rename = cmap or {}
        o_idx = [outs.setdefault(rename.get(c.label, c.label), len(outs)) for c in run.outputs]
        i_idx = [ins.setdefault(rename.get(c.label, c.label), len(ins)) for c in run.inputs]
        for a, o in enumerate(o_idx):
            for b, i in enumerate(i_idx):
                acc.setdefault((o, i), []).append(run.H[a, b])
    H = np.full((len(outs), len(ins), len(f)), np.nan + 0j)
    for (o, i), values in acc.items():
        H[o, i] = np.mean(values, axis=0)
    if not allow_missing:
        missing = [(o, i) for o in range(len(outs)) for i in range(len(ins)) if (o, i) not in acc]
        if missing:
            ol, il = list(outs), list(ins)
            named = ", ".join(f"{ol[o]}/{il[i]}" for o, i in missing[:10])
            raise ValueError(f"{len(missing)} output/input pairs were not measured: {named}")
    return FRFData.from_labels(f, H, list(outs), list(ins), runs[0].quantity, runs[0].units)
