"""What a calibration returns: typed results for its starts, cycles, parameters and modes.

Scaled parameters p are as in :mod:`femcal.calibrate.parameters` (P = P0 (1 + p)); bounds and
errors of p are fractions of the nominal value. Deviations are the metric's squared
residuals summed (:func:`femcal.calibrate.metric.deviation`). The JSON report and the
pictures are made from these at the edge (:mod:`femcal.io.calibration`,
:mod:`femcal.viz.calibration`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..identify.workflow import IdentifiedModel
from ..model.model import Model
from ..solve.normal_modes import Modes
from ..testdata.data import Channel, FRFData
from .augment import AddedElement
from .channels import SuspectChannel
from .config import Config
from .holdout import HoldOut
from .identifiability import Identifiability
from .modelform import ModelForm
from .parameters import Parameter
from .prior import Likelihood, Posterior, Prior


@dataclass(frozen=True)
class StartResult:
    """One Levenberg-Marquardt run from a start point.

    Attributes
    ----------
    start : 0-based index of the start. p0, p : (n_p,) start and end point.
    cost : |r|^2 / 2 at p, regularisation included; deviation : the data part (eps^T eps).
    iterations, evaluations : accepted steps and residual evaluations.
    history : (iterations + 1,) deviation (regularisation included) after each accepted
        step, the first at the start.
    converged, message : why it stopped. seconds : its run time.
    """

    start: int
    p0: np.ndarray
    p: np.ndarray
    cost: float
    deviation: float
    iterations: int
    evaluations: int
    history: tuple[float, ...]
    converged: bool
    message: str
    seconds: float

    def to_dict(self) -> dict:
        """JSON-ready: arrays as lists."""
        return {"start": self.start, "p0": [float(x) for x in self.p0],
                "p": [float(x) for x in self.p], "cost": self.cost, "deviation": self.deviation,
                "iterations": self.iterations, "evaluations": self.evaluations,
                "history": list(self.history), "converged": self.converged,
                "message": self.message, "seconds": self.seconds}  # fmt: skip

    @classmethod
    def from_dict(cls, d: dict) -> StartResult:
        """What :meth:`to_dict` wrote.

        Raises
        ------
        KeyError, TypeError, ValueError
            For a dict that is not one.
        """
        return cls(int(d["start"]), np.asarray(d["p0"], float), np.asarray(d["p"], float),
                   float(d["cost"]), float(d["deviation"]), int(d["iterations"]),
                   int(d["evaluations"]), tuple(float(h) for h in d["history"]),
                   bool(d["converged"]), str(d["message"]), float(d["seconds"]))  # fmt: skip


@dataclass(frozen=True)
class Cycle:
    """One cycle of the search: the multi-start search on the nominal surrogate (cycle 1),
    or a trust-region step on the surrogate rebuilt at the candidate (cycles 2...).

    Attributes
    ----------
    cycle : 1, 2, ...
    center : (n_p,) the centre after the cycle (the candidate where it was kept).
    p, deviation : the point the cycle proposes next and its deviation on the surrogate (the
        centre and its full-model deviation where the cycles stopped).
    best_start : 1-based start that found ``p``.
    starts : the starts run in the cycle.
    exact_deviation_at_center, moved : cycle 1: the full model's deviation at the nominal
        point, the largest |p| of the best start.
    candidate : cycles 2...: the point tried, its full-model deviation
        ``exact_deviation_at_candidate``, ``rho`` the actual over the predicted fall of the
        cost, whether it was ``accepted``, the trust ``radius`` of the step, whether it came
        ``from_search`` (a multi-start search) and how far the informed parameters
        ``moved_informed``.
    searched : the multi-start search ran again in this cycle; its best deviation on the
        surrogate ``search_best_deviation``.
    """

    cycle: int
    center: np.ndarray
    p: np.ndarray
    deviation: float
    best_start: int
    starts: tuple[StartResult, ...] = ()
    exact_deviation_at_center: float | None = None
    moved: float | None = None
    candidate: np.ndarray | None = None
    exact_deviation_at_candidate: float | None = None
    rho: float | None = None
    accepted: bool = True
    radius: float | None = None
    from_search: bool = False
    moved_informed: float | None = None
    searched: bool = False
    search_best_deviation: float | None = None


@dataclass(frozen=True)
class ParameterResult:
    """One parameter after calibration.

    Attributes
    ----------
    parameter : its definition (card, id, field, nominal, bounds).
    calibrated : the calibrated value P; p : its scaled change.
    held : kept at the nominal value: the test cannot inform it (see ``reason``).
    prior_std_p : the prior's standard deviation of p.
    posterior_std_p : the posterior's at the solution (0 where held); posterior_std : the
        same in the field's units (|P0| posterior_std_p).
    ratio : posterior over prior standard deviation (1 where held).
    crlb_p : the data-only Cramér-Rao bound of p with the same likelihood (inf: the test does
        not inform it); crlb : in the field's units.
    identifiable : calibrated, and ``ratio`` below the configuration's ``identifiable_ratio``.
    at_bound : p ended on a bound.
    reason : why it is held, identifiable or weakly informed (the analysis before the search).
    true, true_p, error_pct, error_over_std : with a synthetic test's known values: the true
        value and scaled change, the error of the calibrated value (% of the true one), and
        |p - true_p| over the posterior standard deviation (None where that is zero).
    """

    parameter: Parameter
    calibrated: float
    p: float
    held: bool
    prior_std_p: float
    posterior_std_p: float
    posterior_std: float
    ratio: float
    crlb_p: float
    crlb: float
    identifiable: bool
    at_bound: bool
    reason: str = ""
    true: float | None = None
    true_p: float | None = None
    error_pct: float | None = None
    error_over_std: float | None = None


@dataclass(frozen=True)
class ModePairing:
    """A test mode and the FE modes paired with it (by MAC and frequency) before and after.

    Attributes
    ----------
    test_mode : 1-based; test_hz : its frequency.
    fe_before, fe_after : 1-based FE modes paired with it (None: none paired); their
        frequencies ``fe_before_hz``, ``fe_after_hz``, MAC values ``mac_before``,
        ``mac_after`` and frequency errors (f_test - f_FE) / f_FE in %.
    pseudo_orthogonality_after : |test^T M_SEREP FE| of the pair after calibration, where the
        FE mode is one of the SEREP basis's.
    """

    test_mode: int
    test_hz: float
    fe_before: int | None
    fe_before_hz: float | None
    mac_before: float | None
    frequency_error_before_pct: float | None
    fe_after: int | None
    fe_after_hz: float | None
    mac_after: float | None
    frequency_error_after_pct: float | None
    pseudo_orthogonality_after: float | None


@dataclass(frozen=True)
class BandBounds:
    """The posterior standard deviations (n_p,) of the scaled parameters from one frequency
    band's residuals alone (with the same prior and likelihood)."""

    band_hz: tuple[float, float]
    std: np.ndarray


@dataclass(frozen=True)
class CaseResult:
    """One configuration's outcome.

    Attributes
    ----------
    name : the configuration's. model : its nominal model. data : its measured FRFs (None
        where only an identified model was given). identified : its identified test model,
        if any. index : (n_p_c,) its parameters' positions in the shared set.
    band : Hz. zeta0 : the equalised damping ratio. freq : (n_f,) Hz, the metric's
        frequencies.
    outputs, inputs : the channels compared; excluded : outputs left out as suspect.
    H_test, H_before, H_after : (n_out, n_in, n_f) the damping-equalised test FRFs and the FE
        model's before and after calibration, in the test's quantity.
    deviation_before, deviation_after : the full model's deviation.
    frf_modes : the FE FRFs' number of modes.
    likelihood : how its residuals were weighed (:mod:`femcal.calibrate.prior`).
    test_hz, test_shapes : (k,), (n_out, k) the identified test modes in the band.
    modes_before, modes_after : the full model's modes at the nominal and calibrated point.
    mac_before, mac_after : (k, n_modes) MAC of the test modes against the FE modes.
    modes : the test modes with their pairings.
    model_form : where the calibrated model still misses the test, and what it may lack.
    channel_names : channel label -> the sensor's or input's own name (may be empty).
    suspects : the outputs whose misfit stands out before or after calibration, with their
        likely reasons (:mod:`femcal.correlate.channels`).
    """

    name: str
    model: Model
    data: FRFData | None
    identified: IdentifiedModel | None
    index: np.ndarray
    band: tuple[float, float]
    zeta0: float
    freq: np.ndarray
    outputs: tuple[Channel, ...]
    inputs: tuple[Channel, ...]
    excluded: tuple[Channel, ...]
    H_test: np.ndarray
    H_before: np.ndarray
    H_after: np.ndarray
    deviation_before: float
    deviation_after: float
    frf_modes: int
    likelihood: Likelihood
    test_hz: np.ndarray
    test_shapes: np.ndarray
    modes_before: Modes
    modes_after: Modes
    mac_before: np.ndarray
    mac_after: np.ndarray
    modes: tuple[ModePairing, ...]
    model_form: ModelForm | None = None
    channel_names: dict[str, str] = field(default_factory=dict)
    suspects: tuple[SuspectChannel, ...] = ()

    def channel_name(self, channel: Channel) -> str:
        """The channel's sensor name and label (``L03 +Z (455:+Z)``), or its label."""
        own = self.channel_names.get(channel.label)
        return f"{own} ({channel.label})" if own else channel.label


@dataclass(frozen=True)
class CalibrationResult:
    """A calibration run and its outcome.

    Attributes
    ----------
    config : the run's settings.
    parameters : per (shared) parameter, the outcome. p_final : (n_p,) scaled solution.
    cases : per configuration, its outcome (one for a single deck and test).
    cycles : every cycle of the search. settled : the informed parameters stopped moving
        before the cycles ran out.
    prior : the parameters' prior (:mod:`femcal.calibrate.prior`).
    identifiability : the analysis at the nominal model before the search.
    posterior : at the solution. band_bounds : the posterior per band.
    holdout : the validation on data the fit did not see (None: not run).
    seconds : the run's wall time.
    augmented : the calibration again with the element the model-form search named added
        as a parameter (None: not run; :mod:`femcal.calibrate.augment`).
    augment_error : why that element could not be added (None: no error).
    """

    config: Config
    parameters: tuple[ParameterResult, ...]
    p_final: np.ndarray
    cases: tuple[CaseResult, ...]
    cycles: tuple[Cycle, ...]
    settled: bool
    prior: Prior
    identifiability: Identifiability
    posterior: Posterior
    band_bounds: tuple[BandBounds, ...]
    seconds: float
    holdout: HoldOut | None = None
    augmented: Augmentation | None = None
    augment_error: str | None = None

    @property
    def restarts(self) -> int:
        """How often the multi-start search ran again after the first cycle."""
        return sum(c.searched for c in self.cycles)

    @property
    def params(self) -> list[Parameter]:
        """The parameter definitions, in order."""
        return [r.parameter for r in self.parameters]

    @property
    def values(self) -> np.ndarray:
        """(n_p,) the calibrated values P."""
        return np.array([r.calibrated for r in self.parameters])

    @property
    def deviation_before(self) -> float:
        """Every configuration's full-model deviation before calibration, summed."""
        return float(sum(c.deviation_before for c in self.cases))

    @property
    def deviation_after(self) -> float:
        """Every configuration's full-model deviation after calibration, summed."""
        return float(sum(c.deviation_after for c in self.cases))


@dataclass(frozen=True)
class Augmentation:
    """A calibration run again with the missing element its model-form search named, added
    to a configuration's deck as a parameter (:mod:`femcal.calibrate.augment`).

    Attributes
    ----------
    added : the element and its parameter (its cards: femcal.io.calibration.element_cards).
    result : the calibration with it (its parameters: the first's and the added one).
    deck : the configuration's deck with the element added (the calibration's input).
    better : the held-out data prefer the model with the element (None: no held-out data to
        judge by); reason : the figures that say so, in words.
    """

    added: AddedElement
    result: CalibrationResult
    deck: Path
    better: bool | None
    reason: str

    @property
    def parameter_result(self) -> ParameterResult:
        """The added element's parameter as the calibration with it left it."""
        name = self.added.parameter.name
        return next(q for q in self.result.parameters if q.parameter.name == name)

    @property
    def warning_remains(self) -> bool:
        """The calibration with the element still warns of model form."""
        return any(c.model_form is not None and c.model_form.warning for c in self.result.cases)
