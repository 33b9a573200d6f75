"""Model-form diagnostics: a feature the model lacks is found where it is. The test FRFs come
from the plate with a spring to ground (or a mass) the model does not have; the search over
every DOF must name that place, component and size."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from femcal.calibrate.metric import residuals
from femcal.calibrate.modelform import (
    band_edges,
    diagnose,
    measured_scatter,
    missing_elements,
    robust_weights,
)
from femcal.model import EigenRequest
from femcal.model.build import load_model
from femcal.response.frf import channel_matrix, modal_frf
from femcal.solve.normal_modes import solve_normal_modes
from femcal.testdata.data import Channel, FRFData

from .calib_decks import plate_deck

OUTS = [Channel.parse(f"{g}:+Z") for g in (3, 5, 7, 10, 12, 14, 17, 19, 21, 24, 26, 28)]
INS = [Channel.parse("28:+Z"), Channel.parse("11:+Z")]
ZETA = 0.02


@pytest.fixture()
def frf(tmp_path):
    def make(deck: str, f: np.ndarray):
        path = tmp_path / f"deck{len(list(tmp_path.iterdir()))}.bdf"
        path.write_text(deck)
        return _frf(load_model(path), f)

    return make


def _frf(model, f: np.ndarray):
    modes, _ = solve_normal_modes(model, request=EigenRequest(nd=30))
    H = modal_frf(modes.shapes, modes.radians, channel_matrix(model, OUTS),
                  channel_matrix(model, INS).T, f, ZETA, "accelerance")  # fmt: skip
    return model, modes, H


@pytest.mark.parametrize("extra, kind, grid, component, size", [
    ("CELAS2,600,30.,19,3", "spring to ground", 19, 3, 30.0),
    ("CONM2,601,10,,0.0005", "point mass", 10, 0, 0.0005),
])  # fmt: skip
def test_a_missing_spring_or_mass_is_found_where_it_is(frf, extra, kind, grid, component,
                                                        size):  # fmt: skip
    f = np.geomspace(10.0, 400.0, 300)
    model, modes, H_model = frf(plate_deck(), f)
    _, _, H_test = frf(plate_deck().replace("ENDDATA", extra + "\nENDDATA"), f)
    eps = residuals(H_model, H_test, "complex-log")
    found = missing_elements(model, modes, OUTS, INS, f, ZETA, eps, H_model, H_test,
                             "complex-log")  # fmt: skip
    best = found[0]
    assert (best.kind, best.grid, best.component) == (kind, grid, component)
    assert best.value == pytest.approx(size, rel=0.02)  # sized exactly on the modal model
    assert best.fall > 0.99  # the one element explains the misfit
    assert all(c.fall <= best.fall for c in found)


@pytest.mark.parametrize("extra, kind, grid, component, size", [
    ("CELAS2,600,3000.,19,3", "spring to ground", 19, 3, 3000.0),
    ("CONM2,601,10,,0.01", "point mass", 10, 0, 0.01),
])  # fmt: skip
def test_a_missing_element_that_moves_resonances_far_is_found_too(frf, extra, kind, grid,
                                                                   component, size):  # fmt: skip
    """Large enough to move modes by several half-power bandwidths, where the misfit's
    first-order gain says little: the exact screening still names the grid, the component
    and the size."""
    f = np.geomspace(10.0, 400.0, 300)
    model, modes, H_model = frf(plate_deck(), f)
    _, modes_test, H_test = frf(plate_deck().replace("ENDDATA", extra + "\nENDDATA"), f)
    shift = np.abs(modes_test.frequencies_hz[:6] / modes.frequencies_hz[:6] - 1.0)
    assert shift.max() > 4 * ZETA  # beyond the first order's reach
    eps = residuals(H_model, H_test, "complex-log")
    best = missing_elements(model, modes, OUTS, INS, f, ZETA, eps, H_model, H_test,
                            "complex-log", weights=robust_weights(eps))[0]  # fmt: skip
    assert (best.kind, best.grid, best.component) == (kind, grid, component)
    assert best.value == pytest.approx(size, rel=0.05)
    assert best.fall > 0.95


@pytest.mark.parametrize("f, metric", [
    (np.array([50.0]), "complex-log"),  # a single frequency: both screens use it
    (np.geomspace(10.0, 400.0, 300), "log-magnitude"),
])  # fmt: skip
def test_the_search_works_on_one_frequency_and_on_magnitudes_alone(frf, f, metric):
    model, modes, H_model = frf(plate_deck(), f)
    _, _, H_test = frf(plate_deck().replace("ENDDATA", "CELAS2,600,30.,19,3\nENDDATA"), f)
    eps = residuals(H_model, H_test, metric)
    best = missing_elements(model, modes, OUTS, INS, f, ZETA, eps, H_model, H_test, metric)[0]
    assert (best.kind, best.grid, best.component) == ("spring to ground", 19, 3)
    assert best.value == pytest.approx(30.0, rel=0.01) and best.fall > 0.99


def test_diagnose_says_where_and_what_and_stays_quiet_within_the_noise(frf):
    f = np.geomspace(10.0, 400.0, 300)
    model, modes, H_model = frf(plate_deck(), f)
    _, _, H_test = frf(plate_deck().replace("ENDDATA", "CELAS2,600,30.,19,3\nENDDATA"), f)
    eps = residuals(H_model, H_test, "complex-log")
    test_hz = modes.frequencies_hz[(modes.frequencies_hz > 10) & (modes.frequencies_hz < 400)]
    names = {"19:+Z": "S19 +Z"}
    form = diagnose(model, modes, OUTS, INS, f, ZETA, (10.0, 400.0), test_hz, eps, eps,
                    H_model, H_test, "complex-log", 1e-3, ["k_spring"], names)  # fmt: skip
    assert form.warning and form.typical_after > 2e-3
    text = " ".join(form.suggestions)
    assert "a spring to ground" in text and "GRID 19" in text and "k_spring" in text
    assert "To test it, add a CELAS1 on GRID 19, component 3, and its PELAS of K = " in text
    assert len(form.band_edges_hz) == len(test_hz) + 1
    assert form.output_rms_after.shape == form.output_typical_after.shape == (len(OUTS),)
    assert form.band_typical_after.shape == (len(test_hz),)
    # where the typical misfit is largest, by the sensors' own names
    worst = OUTS[int(np.argmax(form.output_typical_after))].label
    assert f"Typically it is largest at {names.get(worst, worst)}" in text
    quiet = diagnose(model, modes, OUTS, INS, f, ZETA, (10.0, 400.0), test_hz, eps, eps,
                     H_model, H_test, "complex-log", 1.0)  # fmt: skip
    assert not quiet.warning
    assert "no sign of a feature the model lacks" in quiet.suggestions[0]
    # the search still says where it would look, as a conditional
    assert "Were something missing" in quiet.suggestions[1] and "GRID 19" in quiet.suggestions[1]


def test_the_warning_sets_typical_misfit_against_noise_not_the_heavy_tail(frf):
    """A residual at the noise level everywhere but at a few antiresonance points, where it
    is huge: its RMS is far above the noise, its typical size is not, and no warning."""
    f = np.geomspace(10.0, 400.0, 300)
    model, modes, H_model = frf(plate_deck(), f)
    rng = np.random.default_rng(3)
    eps = 0.004 * rng.standard_normal(2 * H_model.size)
    eps[rng.choice(eps.size, eps.size // 20, replace=False)] += 1.0  # 5 % outliers
    H_test = H_model * 10.0 ** (-eps[: H_model.size].reshape(H_model.shape))
    test_hz = modes.frequencies_hz[(modes.frequencies_hz > 10) & (modes.frequencies_hz < 400)]
    form = diagnose(model, modes, OUTS, INS, f, ZETA, (10.0, 400.0), test_hz, eps, eps,
                    H_model, H_test, "complex-log", 0.004)  # fmt: skip
    assert form.misfit_after > 20 * 0.004  # the RMS is the tail's
    assert form.typical_after == pytest.approx(0.004 * 1.1, rel=0.15)
    assert not form.warning


class _Fitted:
    """An identified model's face as measured_scatter sees it: its FRFs and channels."""

    def __init__(self, data: FRFData) -> None:
        self.data, self.outputs, self.inputs = data, data.outputs, data.inputs
        self.fit_error = np.array([0.05])

    def frf(self, freq_hz: np.ndarray) -> FRFData:
        keep = np.isin(self.data.frequency_hz, freq_hz)
        return replace(self.data, frequency_hz=self.data.frequency_hz[keep],
                       H=self.data.H[:, :, keep])  # fmt: skip


def test_measured_scatter_is_the_noise_in_the_metric(frf):
    f = np.linspace(5.0, 400.0, 2000)
    _, _, H = frf(plate_deck(), f)
    clean = FRFData(f, H, tuple(OUTS), tuple(INS), "accelerance", "mm/s^2/N")
    rng = np.random.default_rng(0)
    s = 0.02  # relative complex noise, per real and imaginary part
    noise = s * (rng.standard_normal(H.shape) + 1j * rng.standard_normal(H.shape))
    measured = replace(clean, H=H * (1.0 + noise))
    fitted = _Fitted(clean)
    got = measured_scatter(measured, fitted, OUTS[:6], (10.0, 300.0), "complex-log")
    assert got == pytest.approx(s / np.log(10.0), rel=0.05)
    # the channels compared are the ones asked for, by label, in any order
    reordered = replace(measured, H=measured.H[::-1], outputs=measured.outputs[::-1])
    assert measured_scatter(reordered, fitted, OUTS[:6], (10.0, 300.0),
                            "complex-log") == pytest.approx(got, rel=1e-12)  # fmt: skip
    # without the measured FRFs: the identification's fit error; without a model: unknown
    assert measured_scatter(None, fitted, OUTS, (10.0, 300.0), "complex-log") == pytest.approx(
        0.05 / (np.sqrt(2.0) * np.log(10.0)))
    assert measured_scatter(measured, None, OUTS, (10.0, 300.0), "complex-log") is None


def test_bands_and_robust_weights():
    np.testing.assert_allclose(band_edges(np.array([20.0, 80.0]), (10.0, 100.0)),
                               [10.0, 40.0, 100.0])  # fmt: skip
    assert len(band_edges(np.zeros(0), (10.0, 80.0))) == 4  # octaves
    e = np.array([0.01, -0.01, 0.012, -0.009, 1.0])
    w = robust_weights(e)
    assert w[:4].tolist() == [1.0] * 4 and w[4] < 0.05


def test_noise_alone_points_at_no_element_and_the_report_says_so(frf):
    """Where the misfit is noise, the best candidate removes little: the diagnosis and the
    report's table say that none stands out instead of listing candidates as findings, and
    each size carries its unit."""
    from femcal.calibrate.modelform import USEFUL_FALL
    from femcal.io.calibration import model_form_tables
    from femcal.model.units import element_unit, length_unit

    f = np.geomspace(10.0, 400.0, 300)
    model, modes, H_model = frf(plate_deck(), f)
    rng = np.random.default_rng(4)
    H_test = H_model * (1 + 0.01 * (rng.standard_normal(H_model.shape)
                                    + 1j * rng.standard_normal(H_model.shape)))  # fmt: skip
    eps = residuals(H_model, H_test, "complex-log")
    test_hz = modes.frequencies_hz[(modes.frequencies_hz > 10) & (modes.frequencies_hz < 400)]
    form = diagnose(model, modes, OUTS, INS, f, ZETA, (10.0, 400.0), test_hz, eps, eps,
                    H_model, H_test, "complex-log", 1.0)  # fmt: skip
    assert not form.warning and form.candidates
    assert form.candidates[0].fall < USEFUL_FALL
    assert any("finds none that stands out" in s for s in form.suggestions)
    assert not any("Were something missing" in s for s in form.suggestions)
    length = length_unit(model)
    for c in form.candidates:
        kind = ("mass" if c.kind == "point mass" else
                "translation" if c.component <= 3 else "rotation")  # fmt: skip
        assert c.unit == element_unit(length, kind)
        assert (c.unit in c.describe()) and (c.unit in c.size)
    table = {"warning": False, "noise_sigma": 0.01, "length_unit": length, "bands": [],
             "outputs": [], "candidates": [
                 {"kind": c.kind, "grid": c.grid, "component": c.component,
                  "xyz": list(c.xyz), "fall": c.fall, "value": c.value, "unit": c.unit}
                 for c in form.candidates]}  # fmt: skip
    text, head, rows = model_form_tables(table)[-1]
    assert text.startswith("For reference only") and "none stands out" in text
    assert f"x, y, z ({length})" in head
    assert all(r[4].endswith(c.unit) for r, c in zip(rows, form.candidates, strict=True))


def test_element_units_follow_the_unit_system():
    from femcal.model.units import element_unit

    assert [element_unit("mm", k) for k in ("translation", "rotation", "mass")] == [
        "N/mm", "N mm/rad", "t"]
    assert [element_unit("m", k) for k in ("translation", "rotation", "mass")] == [
        "N/m", "N m/rad", "kg"]
    assert element_unit(None, "mass") == ""


def test_the_single_precision_screen_keeps_the_double_precision_candidates(frf, monkeypatch):
    """The screen ranks candidates in single precision; with a misfit no one element
    explains (measurement-like scatter on top of a missing spring), the candidates kept,
    their sizes and falls are those of a screen in double precision."""
    import femcal.calibrate.modelform as mf

    f = np.geomspace(10.0, 400.0, 200)
    model, modes, H_model = frf(plate_deck(), f)
    _, _, H_test = frf(plate_deck().replace("ENDDATA", "CELAS2,600,300.,19,3\nENDDATA"), f)
    rng = np.random.default_rng(11)
    H_test = H_test * np.exp(0.05 * (rng.standard_normal(H_test.shape)
                                     + 1j * rng.standard_normal(H_test.shape)))  # fmt: skip
    eps = residuals(H_model, H_test, "complex-log")

    def search() -> tuple:
        return missing_elements(model, modes, OUTS, INS, f, ZETA, eps, H_model, H_test,
                                "complex-log")  # fmt: skip

    single = search()
    monkeypatch.setattr(mf, "SCREEN_DTYPE", np.complex128)
    double = search()
    assert len(single) == len(double) > 1
    for a, b in zip(single, double, strict=True):
        assert (a.kind, a.grid, a.component) == (b.kind, b.grid, b.component)
        assert a.fall == pytest.approx(b.fall, rel=1e-9, abs=1e-12)
        assert a.value == pytest.approx(b.value, rel=1e-9)
