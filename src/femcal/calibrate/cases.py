"""The configurations a calibration compares, each prepared for the search.

A calibration may compare several configurations of one structure (the frame hammer-tested
on its bellows and the same frame on the rig, say), each its own model and test; their
parameters are one set, shared by name (:func:`femcal.calibrate.parameters.share_parameters`).
For each configuration the test side is made ready here: channels the identification calls
suspect are left out, every identified test pole gets the damping zeta0 (the median
identified damping by default) with its damped frequency kept (damping equalisation), and
the metric's frequencies are spaced a few per half-power bandwidth.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import ConfigError
from ..identify import IdentifiedModel, equalize_damping
from ..model.model import Model
from ..testdata.data import Channel, FRFData
from .config import MAX_FREQUENCIES, Config, n_frequencies
from .derivatives import group_polynomials
from .metric import log_frequencies
from .parameters import Parameter


@dataclass(frozen=True)
class TestSetup:
    """What one configuration brings to a calibration.

    Attributes
    ----------
    name : the configuration's name (reports and pictures).
    model : its FE model; params : its parameters (on this model), shared by name with the
        other configurations'.
    band : (f_lo, f_hi) Hz, the metric's band.
    data, identified : the measured FRFs and/or an identified model of them (at least one;
        with an identified model its poles, shapes and suspect channels are used).
    zeta0 : the equalised damping ratio; None: the identified median in the band.
    units : the model's FRF units; test data in other units is refused (None: not checked).
    channel_names : channel label -> the sensor's or input's own name (``455:+Z`` ->
        ``L03 +Z``), for reports and pictures.
    """

    name: str
    model: Model
    params: tuple[Parameter, ...]
    band: tuple[float, float]
    data: FRFData | None = None
    identified: IdentifiedModel | None = None
    zeta0: float | None = None
    units: str | None = None
    channel_names: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Case:
    """A configuration prepared for the search.

    Attributes
    ----------
    setup : what it was made from. index : (n_p_c,) its parameters' positions in the shared
        set.
    outputs, inputs : the channels compared; excluded : outputs left out as suspect.
    quantity : the FRFs' (receptance, mobility or accelerance).
    zeta0 : the equalised damping ratio. freq : (n_f,) Hz, the metric's frequencies.
    H_test : (n_out, n_in, n_f) the damping-equalised test FRFs (or the measured ones at
        the measured frequencies nearest to the metric's, without an identified model).
    test_hz, test_shapes : (k,), (n_out, k) the identified test modes in the band (none
        without an identified model).
    polynomials : the exact dependence of the model's K and M on its parameters
        (:func:`femcal.calibrate.derivatives.group_polynomials`).
    """

    setup: TestSetup
    index: np.ndarray
    outputs: tuple[Channel, ...]
    inputs: tuple[Channel, ...]
    excluded: tuple[Channel, ...]
    quantity: str
    zeta0: float
    freq: np.ndarray
    H_test: np.ndarray
    test_hz: np.ndarray
    test_shapes: np.ndarray
    polynomials: object

    @property
    def name(self) -> str:
        return self.setup.name

    @property
    def model(self) -> Model:
        return self.setup.model

    @property
    def params(self) -> tuple[Parameter, ...]:
        return self.setup.params


def _test_frfs(data: FRFData | None, ident: IdentifiedModel | None, keep: np.ndarray,
               zeta0: float, freq: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """(frequencies, H_X (n_out, n_in, n_f)): the damping-equalised identified model at
    ``freq``, or, without an identified model, the measured FRFs at the measured frequencies
    nearest to ``freq`` (no interpolation: it would bend the resonance peaks)."""
    if ident is not None:
        H = equalize_damping(ident, zeta0).frf(freq).H
        if ident.layout is not None and ident.layout.transposed:
            H = np.swapaxes(H, 0, 1)  # the roving side as outputs (see prepare_case)
        return freq, H[keep]
    f = data.frequency_hz
    if freq[0] < f[0] * (1 - 1e-9) or freq[-1] > f[-1] * (1 + 1e-9):
        raise ValueError(f"the calibration band {freq[0]:g}-{freq[-1]:g} Hz lies outside the "
                         f"test data ({f[0]:g}-{f[-1]:g} Hz)")  # fmt: skip
    pos = np.clip(np.searchsorted(f, freq), 1, len(f) - 1)
    idx = np.unique(np.where(freq - f[pos - 1] <= f[pos] - freq, pos - 1, pos))
    return f[idx], data.H[keep][:, :, idx]


def prepare_case(setup: TestSetup, index: np.ndarray, cfg: Config,
                 say: Callable[[str], None]) -> Case:  # fmt: skip
    """The configuration ready for the search (see the module docstring).

    Raises
    ------
    ValueError
        Naming the configuration: no test given, test data in other units than the model's,
        a band without identified test modes or without data, test FRFs that are zero in it.
    """
    at = f"configuration {setup.name}"
    data, ident, units = setup.data, setup.identified, setup.units
    if data is None and ident is None:
        raise ValueError(f"{at}: the calibration needs the test FRFs or an identified test "
                         "model")  # fmt: skip
    for what, test in (("test FRFs", data), ("identified test model", ident)):
        if test is not None and units and test.units and test.units != units:
            raise ValueError(f"{at}: the {what} are in {test.units}, the FE model in {units}: "
                             "convert them first (femcal.testdata.convert_units)")  # fmt: skip
    if ident is not None:
        # the identified model's roving side (the outputs, or the hammer points of a
        # roving-hammer set) is where its shapes are: the FRFs are compared in that layout,
        # which the FE model's reciprocity (symmetric K and M) leaves as they are
        rows, cols = ident.shape_channels, ident.reference_channels
        if ident.layout is not None and ident.layout.transposed:
            say(f"{setup.name}: a roving-hammer test: compared in its reciprocal layout, "
                f"the {len(rows)} excitation points as outputs")  # fmt: skip
    else:
        rows, cols = data.outputs, data.inputs
    quantity = (ident if ident is not None else data).quantity
    keep = np.ones(len(rows), bool)
    if ident is not None and cfg.exclude_suspect_channels and ident.suspect.any():
        keep = ~ident.suspect
        say(f"{setup.name}: suspect channels left out: "
            + ", ".join(rows[i].label for i in np.flatnonzero(ident.suspect)))
    outputs = tuple(c for c, k in zip(rows, keep, strict=True) if k)
    excluded = tuple(c for c, k in zip(rows, keep, strict=True) if not k)
    band = setup.band
    if ident is not None:
        sel = (ident.frequency_hz >= band[0]) & (ident.frequency_hz <= band[1])
        if not sel.any():
            raise ValueError(f"{at}: no identified test mode lies in the calibration band "
                             f"{band[0]:g}-{band[1]:g} Hz")  # fmt: skip
        test_hz, test_shapes = ident.frequency_hz[sel], ident.shapes[keep][:, sel]
        zeta0 = setup.zeta0 or float(np.median(ident.damping_ratio[sel]))
    else:
        if setup.zeta0 is None:
            raise ValueError(f"{at}: without an identified test model zeta0 must be given")
        test_hz, test_shapes = np.zeros(0), np.zeros((len(outputs), 0))
        zeta0 = float(setup.zeta0)
    n_f = n_frequencies(band, zeta0, cfg.samples_per_bandwidth)
    if n_f > MAX_FREQUENCIES:  # a tiny identified damping with zeta0 = "median"
        source = " (the identified modes' median damping)" if not setup.zeta0 else ""
        raise ConfigError(f"{at}: zeta0 = {zeta0:.3g}{source} and "
                          f"{cfg.samples_per_bandwidth:g} samples per bandwidth over "
                          f"{band[0]:g}-{band[1]:g} Hz ask for {n_f:.3g} frequencies, more "
                          f"than {MAX_FREQUENCIES}: expected a zeta0 given in the "
                          "configuration, or fewer samples per bandwidth")  # fmt: skip
    freq = log_frequencies(band[0], band[1], zeta0, cfg.samples_per_bandwidth)
    try:
        freq, H_test = _test_frfs(data, ident, keep, zeta0, freq)
    except ValueError as e:
        raise ValueError(f"{at}: {e}") from None
    if (np.abs(H_test) == 0).any():
        raise ValueError(f"{at}: the test FRFs are zero somewhere in the band: the log metric "
                         "needs nonzero values")  # fmt: skip
    say(f"{setup.name}: metric {cfg.metric} over {band[0]:g}-{band[1]:g} Hz, {len(freq)} "
        f"frequencies ({cfg.samples_per_bandwidth:g} per half-power bandwidth at zeta0 = "
        f"{zeta0:.4f}), {len(outputs)} outputs x {len(cols)} inputs")  # fmt: skip
    say(f"{setup.name}: the exact dependence of K and M on the {len(setup.params)} parameters, "
        "element group by element group")  # fmt: skip
    polys = group_polynomials(setup.model, list(setup.params), np.zeros(len(setup.params)),
                              constant=True)  # fmt: skip
    return Case(setup, np.asarray(index, int), outputs, tuple(cols), excluded,
                quantity, zeta0, freq, H_test, test_hz, test_shapes, polys)  # fmt: skip


def residual_rows(case: Case, metric: str, *, outputs: Sequence[int] | None = None,
                  inputs: Sequence[int] | None = None,
                  band: tuple[float, float] | None = None) -> np.ndarray:  # fmt: skip
    """(n_residuals,) bool: the case's residuals of the given outputs, inputs and frequency
    band (None: all), in the metric's layout (H_test raveled; complex-log: magnitude part,
    then phase part)."""
    n_o, n_i, n_f = case.H_test.shape
    o = np.zeros(n_o, bool)
    o[slice(None) if outputs is None else np.asarray(outputs, int)] = True
    i = np.zeros(n_i, bool)
    i[slice(None) if inputs is None else np.asarray(inputs, int)] = True
    f = (np.ones(n_f, bool) if band is None
         else (case.freq >= band[0]) & (case.freq <= band[1]))  # fmt: skip
    rows = (o[:, None, None] & i[None, :, None] & f[None, None, :]).ravel()
    return np.concatenate([rows, rows]) if metric == "complex-log" else rows
