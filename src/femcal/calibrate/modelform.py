"""Model-form diagnostics: where the calibrated model still misses the test, and what it may
lack.

When the misfit after calibration stays well above the test's noise, the model lacks
something the structure has, and no value of its parameters can stand for it without bias.
Both are measured alike, in the metric and robustly: the misfit's typical size is the robust
standard deviation of the calibrated model's residual (1.4826 times its median absolute
value), the noise is the same statistic of the measured FRFs' residual about the identified
test model (the scatter that the smooth modal model does not explain). Root mean squares would
not do: near antiresonances the log metric's residuals have a heavy tail (on the bundled test
5 % of them carry 78 % of the squares at the nominal model, 93 % after calibration), so an RMS
misfit is many times the noise even for a model that lacks nothing. The warning is raised
above ``NOISE_FACTOR`` times the noise. A difference the parameters can mimic (a support whose
stiffening a thicker rail also gives) does not show in the misfit at all; the held-out
prediction and a second configuration are the checks for that. Three views say where:

* the residual by sensor and by frequency band (around each test mode), before and after
  calibration: a misfit that calibration cannot lower, concentrated on a few neighbouring
  sensors or one mode, points at a local feature;
* missing elements: at every degree of freedom of a spread of grids, a spring to ground (a
  support, a clamp), and at each of those grids a point mass. Each is added exactly to the
  calibrated model's modal receptance by a rank-one (spring) or rank-three (mass) update,
  ``R' = R - R_.d dZ (I + R_dd dZ)^-1 R_d.`` (dZ = k for a spring on DOF d, -w^2 m for a
  mass on a grid's translations), and the weighted deviation of the updated FRFs is
  computed at a few sizes spanning the DOF's own dynamic stiffness in the band
  (``SCREEN_SIZES``). Exact, not first order: an element large enough to matter moves a
  resonance by more than its half-power bandwidth, where the first-order gain says almost
  nothing (a 20 kg mass missing from the 380 kg hammer frame: 0.06 % of the deviation to
  first order, 28 % exactly). The grids near the best are screened the same way, the best
  candidates (the best few, and the best at a few distinct places) are sized by a golden
  section on the updated deviation, and the best few at distinct places are reported.
  This is error localisation by candidate parameters (Friswell and Mottershead, Finite
  Element Model Updating in Structural Dynamics, ch. 8), with the candidates every DOF
  rather than a list the engineer guesses. The residuals are weighed by Huber's weights
  first: near antiresonances the log metric's residuals are large where the FRFs differ
  little in absolute terms (a few per cent of the residuals can carry most of the squared
  misfit), and unweighted they make every local spring look useful; weighted, the search
  points at what the model lacks (benchmarks/RESULTS.md);
* the parameters on a bound, which stand for something beyond their range.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np

from ..identify import IdentifiedModel
from ..model.model import Model
from ..model.units import element_unit, length_unit
from ..response.frf import channel_matrix
from ..solve.normal_modes import Modes
from ..testdata.data import Channel, FRFData
from .metric import residuals
from .robust import HUBER_C, robust_scale

_LN10 = np.log(10.0)

#: The typical misfit after calibration above this many times the test's noise (both robust
#: standard deviations in the metric) is a model-form warning. A calibrated model of a hidden
#: frame that lacks nothing ends near 0.8 of the noise (s31_none of
#: benchmarks/calibration_trust.py; the test side is the identified, smooth model), so twice
#: the noise is a systematic misfit.
NOISE_FACTOR = 2.0

#: A missing-element candidate that removes at least this fraction of the remaining
#: (robustly weighed) deviation points at something; below it, none stands out.
USEFUL_FALL = 0.05

#: The sizes every candidate is tried at before the best are refined, relative to its DOF's
#: dynamic stiffness in the band: from a thousandth of it (a small change, where the first
#: order holds) to ten times it (the DOF nearly held, or a mass that dominates there).
SCREEN_SIZES = 10.0 ** np.arange(-3.0, 1.01, 1.0)
#: The screen's ratios and deviations are single precision: they only rank candidates (to
#: about 1e-5 of the deviation), and every candidate kept is sized and its fall computed in
#: double precision; single precision halves the screen's memory traffic.
SCREEN_DTYPE = np.complex64

#: The screen's candidates go in blocks whose every complex temporary stays within this many
#: bytes (a handful are alive at once), so a test with many channels and inputs screens in
#: bounded memory, and the chain of elementwise steps on a block runs from the processor's
#: cache rather than from memory (RESULTS.md has the measurement).
SCREEN_BLOCK_BYTES = 4 * 2**20


@dataclass(frozen=True)
class Candidate:
    """A missing element the misfit asks for.

    Attributes
    ----------
    kind : ``spring to ground`` or ``point mass``.
    grid : the GRID; component : 1-6 in the grid's displacement frame (0 for a point mass,
        which acts in all three translations).
    xyz : (3,) the grid's position in the basic frame.
    fall : the fraction of the configuration's deviation that the best-sized element
        removes.
    value : that size, in the model's units (force / length, moment / radian, mass).
    unit : that unit's name (``N/mm``, ``N mm/rad``, ``t`` in mm-tonne-s; "" when the deck's
        materials do not tell the unit system, :func:`femcal.model.units.length_unit`).
    """

    kind: str
    grid: int
    component: int
    xyz: np.ndarray
    fall: float
    value: float
    unit: str = ""

    @property
    def size(self) -> str:
        """The size with its unit: ``2.1e+08 N mm/rad``."""
        return f"{self.value:.3g}" + (f" {self.unit}" if self.unit else "")

    def describe(self) -> str:
        """``a spring to ground at GRID 455 (800, 430, 127.5), component 5 (RY), 2.1e+08``."""
        at = f"GRID {self.grid} ({', '.join(f'{x:.6g}' for x in self.xyz)})"
        if self.kind == "point mass":
            return f"a point mass of {self.size} at {at}"
        name = ("X", "Y", "Z", "RX", "RY", "RZ")[self.component - 1]
        return (f"a spring to ground of {self.size} at {at}, component {self.component} "
                f"({name})")  # fmt: skip

    def how_to_add(self) -> str:
        """The cards that add it to a deck, with the field a calibration parameter takes."""
        if self.kind == "point mass":
            return (f"a CONM2 of mass {self.size} on GRID {self.grid}, with a parameter on "
                    "its M")  # fmt: skip
        return (f"a CELAS1 on GRID {self.grid}, component {self.component}, and its PELAS of "
                f"K = {self.size}, with a parameter on the PELAS's K")  # fmt: skip


@dataclass(frozen=True)
class ModelForm:
    """One configuration's model-form diagnostics.

    Attributes
    ----------
    noise_sigma : the test's noise in the metric, a robust standard deviation in log10 units
        (:func:`measured_scatter`, or the given noise level; None: unknown).
    misfit_before, misfit_after : one residual's RMS (log10) before and after calibration.
    typical_before, typical_after : the residual's robust standard deviation (log10) before
        and after calibration, what the warning sets against the noise.
    output_rms_before, output_rms_after : (n_out,) RMS residual of each output channel.
    output_typical_before, output_typical_after : (n_out,) its robust standard deviation.
    band_edges_hz : (n_b + 1,) the bands' edges: one band around each test mode (edges at
        the geometric means of neighbouring modes), or octaves without test modes.
    band_rms_before, band_rms_after : (n_b,) RMS residual in each band.
    band_typical_before, band_typical_after : (n_b,) its robust standard deviation.
    frequency_rms_before, frequency_rms_after : (n_f,) RMS over the channels at each of the
        metric's frequencies.
    frequency_typical_before, frequency_typical_after : (n_f,) the robust standard deviation
        over the channels at each frequency (what the warning compares, frequency by
        frequency).
    candidates : the missing elements the misfit asks for most, at distinct places.
    warning : the typical misfit after calibration is above NOISE_FACTOR times the noise.
    suggestions : what the model may lack, in words.
    """

    noise_sigma: float | None
    misfit_before: float
    misfit_after: float
    typical_before: float
    typical_after: float
    output_rms_before: np.ndarray
    output_rms_after: np.ndarray
    output_typical_before: np.ndarray
    output_typical_after: np.ndarray
    band_edges_hz: np.ndarray
    band_rms_before: np.ndarray
    band_rms_after: np.ndarray
    band_typical_before: np.ndarray
    band_typical_after: np.ndarray
    frequency_rms_before: np.ndarray
    frequency_rms_after: np.ndarray
    frequency_typical_before: np.ndarray
    frequency_typical_after: np.ndarray
    candidates: tuple[Candidate, ...]
    warning: bool
    suggestions: tuple[str, ...]


def noise_level(identified: IdentifiedModel | None) -> float | None:
    """The test's noise in the metric's units (log10), from its identification's median fit
    error (a relative complex error e spreads e / (sqrt(2) ln 10) on each of the metric's
    parts); None without an identified model."""
    if identified is None or not len(identified.fit_error):
        return None
    return float(np.median(identified.fit_error) / (np.sqrt(2.0) * _LN10))


def measured_scatter(data: FRFData | None, identified: IdentifiedModel | None,
                 outputs: Sequence[Channel], band: tuple[float, float],
                 metric: str) -> float | None:  # fmt: skip
    """The test's noise in the metric: the robust standard deviation of the metric's
    residual between the identified model (as identified, before damping equalisation) and
    the measured FRFs, at the measured frequencies in ``band`` and the channels compared
    (``outputs``). Without the measured FRFs, :func:`noise_level` from the identification's
    fit error; None without an identified model."""
    if identified is None:
        return None
    if data is None:
        return noise_level(identified)
    f = data.frequency_hz
    sel = (f >= band[0]) & (f <= band[1])
    # compared as the calibration compares them: the identified model's roving side as rows
    # (a roving-hammer test transposed, see femcal.calibrate.cases)
    layout = getattr(identified, "layout", None)
    flip = layout is not None and layout.transposed
    rows, cols = ((data.inputs, data.outputs) if flip else (data.outputs, data.inputs))
    labels = [c.label for c in outputs]
    measured = {c.label: k for k, c in enumerate(rows)}
    fitted = {c.label: k for k, c in enumerate(layout.roving if flip else identified.outputs)}
    shared = [lab for lab in labels if lab in measured and lab in fitted]
    refs = layout.references if flip else identified.inputs
    same_inputs = [c.label for c in cols] == [c.label for c in refs]
    if not sel.any() or not shared or not same_inputs:
        return noise_level(identified)
    H_data = np.swapaxes(data.H, 0, 1) if flip else data.H
    H_model = identified.frf(f[sel]).H
    H_model = np.swapaxes(H_model, 0, 1) if flip else H_model
    H_meas = H_data[[measured[lab] for lab in shared]][:, :, sel]
    H_fit = H_model[[fitted[lab] for lab in shared]]
    with np.errstate(divide="ignore", invalid="ignore"):
        eps = residuals(H_fit, H_meas, metric)
    eps = eps[np.isfinite(eps)]
    return robust_scale(eps) if eps.size else noise_level(identified)


def _split(eps: np.ndarray, shape: tuple[int, int, int]) -> np.ndarray:
    """The metric's residual (magnitude part, then phase part for complex-log) as
    (parts, n_out, n_in, n_f)."""
    return eps.reshape(-1, *shape)


def robust_weights(eps: np.ndarray, c: float = HUBER_C) -> np.ndarray:
    """Huber's weights of the residuals: 1 within c robust standard deviations (1.4826 times
    the median absolute residual), c s / |e| beyond."""
    s = robust_scale(eps)
    if not s > 0:
        return np.ones_like(eps)
    return np.minimum(1.0, c * s / np.maximum(np.abs(eps), 1e-300))


def band_edges(test_hz: np.ndarray, band: tuple[float, float]) -> np.ndarray:
    """One band around each test mode, or octaves from the band's bottom without modes."""
    f = np.sort(np.asarray(test_hz, float))
    if len(f):
        inner = np.sqrt(f[:-1] * f[1:])
        return np.concatenate([[band[0]], inner, [band[1]]])
    n = max(int(np.ceil(np.log2(band[1] / band[0]))), 1)
    return np.geomspace(band[0], band[1], n + 1)


def _rms(x: np.ndarray, axis) -> np.ndarray:
    return np.sqrt(np.mean(x**2, axis=axis))


def _typical(x: np.ndarray) -> np.ndarray:
    """(n_f,) the robust standard deviation over parts and channels at each frequency."""
    return robust_scale(x.reshape(-1, x.shape[-1]), axis=0)


def _sample_grids(xyz: np.ndarray, target: int) -> np.ndarray:
    """Indices of at most about ``target`` points spread over ``xyz`` (n, 3): the point
    nearest each occupied cell's centre of a cubic grid whose cell is sized to the target."""
    if len(xyz) <= target:
        return np.arange(len(xyz))
    lo = xyz.min(axis=0)
    span = float(np.ptp(xyz, axis=0).max()) or 1.0
    edge = span / target ** (1 / 3)
    for _ in range(30):
        cells = np.floor((xyz - lo) / edge).astype(np.int64)
        keys, inverse = np.unique(cells, axis=0, return_inverse=True)
        if len(keys) <= target:
            break
        edge *= (len(keys) / target) ** 0.5
    inverse = inverse.ravel()
    dist = np.linalg.norm(xyz - (lo + (cells + 0.5) * edge), axis=1)
    order = np.lexsort((dist, inverse))
    first = np.ones(len(order), bool)
    first[1:] = inverse[order][1:] != inverse[order][:-1]
    return np.sort(order[first])


def missing_elements(model: Model, modes: Modes, outputs: Sequence[Channel],
                     inputs: Sequence[Channel], freq: np.ndarray, zeta: float,
                     eps: np.ndarray, H_model: np.ndarray, H_test: np.ndarray, metric: str,
                     *, n_best: int = 5, n_sites: int = 1500,
                     min_distance: float | None = None,
                     weights: np.ndarray | None = None) -> tuple[Candidate, ...]:  # fmt: skip
    """The springs to ground and point masses whose best size lowers the deviation most, at
    distinct places (see the module docstring).

    Every DOF of up to ``n_sites`` grids spread over the model is screened exactly at
    ``SCREEN_SIZES`` (every other frequency), then the grids near the best screened ones
    (the other frequencies), and the best of those are sized by a golden section at all
    frequencies.

    Parameters
    ----------
    modes : the calibrated model's modes (g-set shapes) that its FRFs sum, with modal
        damping ``zeta``.
    eps : the metric's residual of the calibrated model against the test (unweighted).
    H_model, H_test : (n_out, n_in, n_f) the calibrated model's and the test's FRFs.
    min_distance : candidates closer than this to a better one are left out (default: 5 % of
        the model's size).
    weights : (n_residuals,) each residual's weight in the deviation (default 1).
    """
    shape = H_test.shape
    wts = np.ones_like(eps) if weights is None else np.asarray(weights, float)
    total = float(eps @ (wts * eps))
    grids = np.flatnonzero(model.is_grid)
    if total <= 0 or not len(grids):
        return ()
    w = 2 * np.pi * np.asarray(freq, float)
    gm = np.asarray(modes.generalized_mass, float)
    Phi = np.asarray(modes.shapes) / np.sqrt(np.where(gm > 0, gm, 1.0))
    lam = np.asarray(modes.eigenvalues, float)
    wr = np.sqrt(np.abs(lam))
    G = 1.0 / (lam[None, :] - w[:, None] ** 2 + 2j * zeta * wr[None, :] * w[:, None])  # (f, m)
    PO = np.asarray(channel_matrix(model, outputs) @ Phi)  # (o, m)
    PI = np.asarray(channel_matrix(model, inputs) @ Phi)  # (i, m)
    R = np.einsum("or,fr,ir->oif", PO, G, PI, optimize=True)  # the modal receptance
    complex_log = metric == "complex-log"
    wparts = _split(wts, shape)

    def deviations(ratio: np.ndarray, fsel: np.ndarray) -> np.ndarray:
        """(c,) the weighted deviation of model-over-test ratios (c, o, i, f) at ``fsel``,
        without trigonometry: log10|r| = ln(|r|^2) / (2 ln 10), and the phase part's square
        (2 sin(arg r / 2))^2 = 2 (1 - Re r / |r|); each part's sum over o, i, f is one
        product with its weights."""
        n_c = ratio.shape[0]
        real = ratio.real.dtype
        with np.errstate(divide="ignore", invalid="ignore"):
            a2 = ratio.real**2 + ratio.imag**2
            log_a2 = np.log(a2)
            dev = (log_a2 * log_a2).reshape(n_c, -1) @ (
                wparts[0][..., fsel] / (4.0 * _LN10**2)).ravel().astype(real)
            if complex_log:
                dev += (1.0 - ratio.real / np.sqrt(a2)).reshape(n_c, -1) @ (
                    wparts[1][..., fsel] * (2.0 / _LN10**2)).ravel().astype(real)
        return np.where(np.isfinite(dev), dev.astype(float), np.inf)

    def screen(dofs: np.ndarray, mass: bool, fsel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(fall, size) of the best of ``SCREEN_SIZES`` for candidates on ``dofs`` (n_c, k):
        a spring on each single DOF (k = 1) or a mass on each grid's translations (k = 3),
        each added exactly to the modal receptance at the frequencies ``fsel``. The sizes
        are relative to the DOF's own dynamic stiffness in the band (the inverse of the
        median driving-point receptance, times w^2 for a mass), so one set serves every
        DOF, translation or rotation, in any units. With the candidate the model's FRFs
        become H (R - dR) / R, so the ratio to the test's is ``base - dR g`` with
        ``base = H / H_test`` and ``g = base / R`` made once."""
        fall = np.full(len(dofs), -np.inf)
        best = np.zeros(len(dofs))
        Gf, w2 = G[fsel], w[fsel] ** 2
        base = (H_model / H_test)[..., fsel]
        with np.errstate(divide="ignore", invalid="ignore"):
            g = base / R[..., fsel]  # (o, i, f)
        ref_dev = deviations(base[None].astype(SCREEN_DTYPE), fsel)[0]
        base, g = base.astype(SCREEN_DTYPE), g.astype(SCREEN_DTYPE)
        # candidates per block: each complex (c, o, i, f) temporary within SCREEN_BLOCK_BYTES
        per = 16 * max(len(outputs) * len(inputs) * len(fsel), dofs.shape[1] * len(fsel)
                       * (len(outputs) + len(inputs) + dofs.shape[1]))  # fmt: skip
        chunk = int(np.clip(SCREEN_BLOCK_BYTES // per, 1, 256))
        for a in range(0, len(dofs), chunk):
            P = Phi[dofs[a:a + chunk]]  # (c, k, m)
            k = P.shape[1]
            Rod = np.einsum("om,fm,ckm->fcok", PO, Gf, P, optimize=True)
            Rdi = np.einsum("ckm,fm,im->fcki", P, Gf, PI, optimize=True)
            Rdd = np.einsum("ckm,fm,clm->fckl", P, Gf, P, optimize=True)
            flex = np.abs(np.trace(Rdd, axis1=2, axis2=3)) / k  # (f, c)
            flex = np.median(flex * (w2[:, None] if mass else 1.0), axis=0)
            reach = flex > 0  # a DOF no mode moves cannot be a candidate
            ref = np.where(reach, 1.0 / np.where(reach, flex, 1.0), 0.0)
            eye = np.eye(k)[None, None]
            if k == 1:  # (c, o, 1, f) and (c, 1, i, f) g: their product is R_o. R_.i g
                out_d = Rod[..., 0].transpose(1, 2, 0).astype(SCREEN_DTYPE)[:, :, None, :]
                d_in = Rdi[..., 0, :].transpose(1, 2, 0).astype(SCREEN_DTYPE)[:, None] * g[None]
            for rel in SCREEN_SIZES:
                size = ref * rel  # (c,)
                dz = (-w2[:, None] * size[None, :] if mass
                      else np.broadcast_to(size[None, :], (len(fsel), len(size))))  # fmt: skip
                if k == 1:  # Sherman-Morrison
                    core = (dz / (1.0 + Rdd[..., 0, 0] * dz)).T.astype(SCREEN_DTYPE)  # (c, f)
                    ratio = base[None] - (out_d * core[:, None, None, :]) * d_in
                else:
                    core = np.linalg.solve(eye + Rdd * dz[..., None, None],
                                           eye * dz[..., None, None])  # fmt: skip
                    dR = np.einsum("fcok,fckl,fcli->coif", Rod, core, Rdi, optimize=True)
                    ratio = base[None] - dR.astype(SCREEN_DTYPE) * g[None]
                got = 1.0 - deviations(ratio, fsel) / ref_dev
                got = np.where(reach, got, -np.inf)
                sl = slice(a, a + len(size))
                better = got > fall[sl]
                fall[sl] = np.where(better, got, fall[sl])
                best[sl] = np.where(better, size, best[sl])
        return fall, best

    length = length_unit(model)

    def unit(kind: str, component: int) -> str:
        return element_unit(length, "mass" if kind == "point mass"
                            else "translation" if component <= 3 else "rotation")  # fmt: skip

    def candidates(nodes: np.ndarray, fsel: np.ndarray) -> list[Candidate]:
        out = []
        start = model.dof_start[nodes]
        springs = (start[:, None] + np.arange(6)[None, :]).reshape(-1, 1)
        masses = start[:, None] + np.arange(3)[None, :]
        for kind, dofs in (("spring to ground", springs), ("point mass", masses)):
            fall, size = screen(dofs, kind == "point mass", fsel)
            for k in np.flatnonzero(fall > 0):
                node, comp = model.dof_owner(dofs[k, 0])
                component = int(comp[0]) if kind == "spring to ground" else 0
                out.append(Candidate(kind, int(model.node_ids[node[0]]), component,
                                     np.asarray(model.xyz[node[0]], float), float(fall[k]),
                                     float(size[k]), unit(kind, component)))  # fmt: skip
        return out

    size = float(np.ptp(model.xyz[grids], axis=0).max()) or 1.0
    min_distance = 0.05 * size if min_distance is None else min_distance
    sites = grids[_sample_grids(model.xyz[grids], n_sites)]
    every = np.arange(len(freq))
    screened = candidates(sites, every[::2])
    screened.sort(key=lambda c: -c.fall)
    spacing = size / max(len(sites), 1) ** (1 / 3)
    near: set[int] = set()
    picked: list[Candidate] = []
    for c in screened:
        if all(np.linalg.norm(c.xyz - b.xyz) >= min_distance for b in picked):
            picked.append(c)
            d = np.linalg.norm(model.xyz[grids] - c.xyz, axis=1)
            near.update(grids[np.argsort(d)[:60]][np.sort(d)[:60] <= 2 * spacing].tolist())
        if len(picked) == 2 * n_best:
            break
    others = every[1::2] if len(every) > 1 else every
    found = candidates(np.array(sorted(near), dtype=np.int64), others) if near else []
    found.sort(key=lambda c: -c.fall)

    def deviation_with(c: Candidate, size: float) -> float:
        """The weighted deviation with the element added at ``size``: the modal receptance
        updated exactly (Sherman-Morrison for a spring, Woodbury over the three translations
        for a mass), the model's FRFs scaled by the update's ratio."""
        node = int(model.node_index(c.grid)[0])
        dofs = model.dof_start[node] + (np.arange(3) if c.kind == "point mass"
                                        else np.array([c.component - 1]))  # fmt: skip
        P = Phi[dofs]  # (k, m)
        Rod = np.einsum("om,fm,km->fok", PO, G, P, optimize=True)
        Rdi = np.einsum("km,fm,im->fki", P, G, PI, optimize=True)
        Rdd = np.einsum("km,fm,lm->fkl", P, G, P, optimize=True)
        n = len(dofs)
        # Z + dZ with dZ = size (spring) or -w^2 size (mass) on the DOF: R' = R - R_.d
        # dZ (I + R_dd dZ)^-1 R_d.
        dz = (size * np.ones(len(freq)) if c.kind == "spring to ground"
              else -(w**2) * size)[:, None, None] * np.eye(n)[None]  # fmt: skip
        core = np.linalg.solve(np.eye(n)[None] + Rdd @ dz, dz)
        R_new = R - np.einsum("fok,fkl,fli->oif", Rod, core, Rdi, optimize=True)
        e = residuals(H_model * (R_new / R), H_test, metric)
        return float(e @ (wts * e))

    def exact(c: Candidate) -> Candidate:
        """The candidate at the size that lowers the deviation most (golden section on the
        logarithm of the size, about the screened size)."""
        lo, hi = np.log(c.value) - np.log(100.0), np.log(c.value) + np.log(100.0)
        ratio = (np.sqrt(5.0) - 1.0) / 2.0
        a, b = hi - ratio * (hi - lo), lo + ratio * (hi - lo)
        fa, fb = deviation_with(c, np.exp(a)), deviation_with(c, np.exp(b))
        for _ in range(40):
            if fa < fb:
                hi, b, fb = b, a, fa
                a = hi - ratio * (hi - lo)
                fa = deviation_with(c, np.exp(a))
            else:
                lo, a, fa = a, b, fb
                b = lo + ratio * (hi - lo)
                fb = deviation_with(c, np.exp(b))
            if hi - lo < 1e-3:
                break
        size, dev = (np.exp(a), fa) if fa < fb else (np.exp(b), fb)
        return replace(c, fall=max(1.0 - dev / total, 0.0), value=float(size))

    # refined: the best few overall and the best at each of a few distinct places
    spread: list[Candidate] = []
    for c in found:
        if all(np.linalg.norm(c.xyz - b.xyz) >= min_distance for b in spread):
            spread.append(c)
        if len(spread) == 2 * n_best:
            break
    chosen = list({id(c): c for c in found[: 3 * n_best] + spread}.values())
    found = sorted((exact(c) for c in chosen), key=lambda c: -c.fall)
    best: list[Candidate] = []
    for c in found:
        if all(np.linalg.norm(c.xyz - b.xyz) >= min_distance for b in best):
            best.append(c)
        if len(best) == n_best:
            break
    return tuple(best)


def diagnose(model: Model, modes: Modes, outputs: Sequence[Channel],
             inputs: Sequence[Channel], freq: np.ndarray, zeta: float, band: tuple[float, float],
             test_hz: np.ndarray, eps_before: np.ndarray, eps_after: np.ndarray,
             H_after: np.ndarray, H_test: np.ndarray, metric: str,
             noise_sigma: float | None, bound_names: Sequence[str] = (),
             channel_names: dict[str, str] | None = None) -> ModelForm:  # fmt: skip
    """One configuration's diagnostics (see the module docstring) from its residuals before
    and after calibration and the calibrated model's modes."""
    shape = H_test.shape
    before, after = _split(eps_before, shape), _split(eps_after, shape)
    names = channel_names or {}
    edges = band_edges(test_hz, band)
    idx = np.clip(np.searchsorted(edges, freq, side="right") - 1, 0, len(edges) - 2)
    n_b = len(edges) - 1

    def by_band(x: np.ndarray, stat) -> np.ndarray:
        return np.array([stat(x[..., idx == b]) if (idx == b).any() else np.nan
                         for b in range(n_b)])  # fmt: skip

    def rms(x: np.ndarray) -> float:
        return float(_rms(x, None))

    band_b, band_a = by_band(before, rms), by_band(after, rms)
    tband_b, tband_a = by_band(before, robust_scale), by_band(after, robust_scale)
    out_b, out_a = _rms(before, (0, 2, 3)), _rms(after, (0, 2, 3))
    tout_b = robust_scale(np.moveaxis(before, 1, 0).reshape(shape[0], -1), axis=1)
    tout_a = robust_scale(np.moveaxis(after, 1, 0).reshape(shape[0], -1), axis=1)
    mis_b, mis_a = float(_rms(eps_before, None)), float(_rms(eps_after, None))
    typ_b, typ_a = robust_scale(eps_before), robust_scale(eps_after)
    warning = noise_sigma is not None and typ_a > NOISE_FACTOR * noise_sigma
    candidates = missing_elements(model, modes, outputs, inputs, freq, zeta, eps_after,
                                  H_after, H_test, metric, weights=robust_weights(eps_after))
    useful = [c for c in candidates if c.fall >= USEFUL_FALL]
    say = []
    levels = (f"The typical misfit after calibration (robust standard deviation {typ_a:.3g} "
              f"in log10, {typ_b:.3g} before)")  # fmt: skip
    if noise_sigma is not None and not warning:
        say.append(f"{levels} is {typ_a / noise_sigma:.3g} times the test's noise "
                   f"({noise_sigma:.2g}, the measured FRFs' scatter about the identified "
                   f"model): within {NOISE_FACTOR:g} times, no sign of a feature the model "
                   "lacks. A difference the parameters can mimic does not show in the "
                   "misfit: the held-out prediction tests for that.")  # fmt: skip
        if useful:
            c = useful[0]
            say.append(f"Were something missing, the likeliest is {c.describe()}: it would "
                       f"remove about {100 * c.fall:.0f} % of the remaining deviation "
                       "(robustly weighed).")  # fmt: skip
        elif candidates:
            say.append("The search for a missing element finds none that stands out: the "
                       "best single spring to ground or point mass removes "
                       f"{100 * candidates[0].fall:.1f} % of the remaining deviation "
                       f"(robustly weighed), less than the {100 * USEFUL_FALL:g} % that would "
                       "point at one.")
    else:
        if noise_sigma is not None:
            say.append(f"{levels} stays {typ_a / noise_sigma:.3g} times the test's noise "
                       f"({noise_sigma:.2g}, the measured FRFs' scatter about the identified "
                       "model).")  # fmt: skip
        else:
            say.append(f"{levels}: the test's noise is unknown (no identified model and no "
                       "noise_sigma), so whether it is noise or model form cannot be told: "
                       "read what follows as where the misfit is, not as what is "
                       "missing.")  # fmt: skip
        worst = np.argsort(tout_a)[::-1][:3]
        label = [names.get(outputs[o].label, outputs[o].label) for o in worst]
        say.append("Typically it is largest at " + ", ".join(
            f"{lab} ({tout_a[o]:.3g})" for lab, o in zip(label, worst, strict=True))
            + f"; the median channel's is {np.median(tout_a):.3g}.")  # fmt: skip
        ok = np.isfinite(tband_a)
        if ok.any():
            b = int(np.nanargmax(np.where(ok, tband_a, -np.inf)))
            mode = (f"around the test mode at {np.sort(test_hz)[b]:.1f} Hz" if len(test_hz)
                    else f"in {edges[b]:.0f}-{edges[b + 1]:.0f} Hz")  # fmt: skip
            say.append(f"By frequency it is largest {mode} ({tband_a[b]:.3g}, "
                       f"{tband_b[b]:.3g} before calibration).")  # fmt: skip
        if useful:
            c = useful[0]
            what = ("a support or a stiffer connection to the surroundings there (a mount, a "
                    "clamp, a cross support)" if c.kind == "spring to ground"
                    else "mass there (a component, a bracket, fluid)")  # fmt: skip
            say.append(f"The model may lack {what}: {c.describe()} would remove about "
                       f"{100 * c.fall:.0f} % of the remaining deviation (robustly "
                       f"weighed). To test it, add {c.how_to_add()} (bounds about a tenth "
                       "to ten times its size), and calibrate again."
                       + ("" if len(useful) == 1 else " Others: " + "; ".join(
                           f"{d.describe()} ({100 * d.fall:.0f} %)" for d in useful[1:3])
                          + "."))  # fmt: skip
        elif candidates:
            say.append("No single spring to ground or point mass removes more than "
                       f"{100 * USEFUL_FALL:g} % of the remaining deviation: what the model "
                       "lacks is spread out (damping, a joint's flexibility along a line, the "
                       "test's own errors).")  # fmt: skip
    if bound_names:
        say.append(f"{', '.join(bound_names)} ended on a bound: each stands for something "
                   "beyond its range; widen the bound only if the physics allows it, else "
                   "look for what it stands for.")  # fmt: skip
    return ModelForm(noise_sigma, mis_b, mis_a, typ_b, typ_a, out_b, out_a, tout_b, tout_a,
                     edges, band_b, band_a, tband_b, tband_a,
                     _rms(before, (0, 1, 2)), _rms(after, (0, 1, 2)),
                     _typical(before), _typical(after), candidates, warning,
                     tuple(say))  # fmt: skip
