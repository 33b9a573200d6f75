"""FRF overlay plots: the panels hold exactly the test and model curves asked for."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.testdata.data import FRFData
from femcal.viz.frf import frf_overlay


def data(scale: float = 1.0) -> FRFData:
    f = np.linspace(1.0, 100.0, 200)
    w = 2 * np.pi * f
    H = np.empty((2, 2, len(f)), complex)
    for o in range(2):
        for i in range(2):
            wn = 2 * np.pi * (30.0 + 10 * o + 5 * i)
            H[o, i] = scale / (wn**2 - w**2 + 2j * 0.02 * wn * w)
    return FRFData.from_labels(f, H, ["1:2", "2:3"], ["5:2", "6:3"], "receptance", "mm/N")


def test_overlay_draws_test_and_model_per_pair(tmp_path):
    test, model = data(), data(1.1)
    path = tmp_path / "overlay.png"
    fig = frf_overlay(path, test, model, pairs=[(0, 1), (1, 0), (1, 1)], title="check")
    assert path.stat().st_size > 10_000 and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    visible = [ax for ax in fig.axes if ax.get_visible()]
    assert len(visible) == 6  # magnitude and phase for 3 pairs
    mag = visible[0]  # first pair's magnitude: test (0, 1) then the model's
    t_line, m_line = mag.get_lines()
    assert np.allclose(t_line.get_ydata(), np.abs(test.H[0, 1]))
    assert np.allclose(m_line.get_ydata(), np.abs(model.H[0, 1]))
    assert mag.get_title() == "1:2 / 6:3"
    assert not list(tmp_path.glob(".*"))


def test_overlay_refuses_a_model_without_the_channel(tmp_path):
    other = FRFData.from_labels(data().frequency_hz, data().H, ["9:1", "2:3"], ["5:2", "6:3"])
    with pytest.raises(ValueError, match="no FRF 1:2 / 5:2"):
        frf_overlay(tmp_path / "x.png", data(), other)


def test_the_length_unit_of_frf_units():
    from femcal.viz.calibration import length_unit

    assert length_unit("mm/s^2/N") == "mm"
    assert length_unit("m/N") == "m"
    assert length_unit("in/lbf") == "in"
    assert length_unit("g/N") == "model length unit"
    assert length_unit("") == length_unit(None) == "model length unit"


def test_unreadable_axes_are_found_and_readable_ones_pass():
    from femcal.viz.figures import pyplot, unlabelled_axes

    plt = pyplot()
    fig, axes = plt.subplots(2, 2, sharex=True)
    a, b, c, d = axes.ravel()
    a.set_title("bare")  # no labels at all, its x ticks hidden by the shared axis
    b.set(title="words", ylabel="response")  # a quantity without a unit
    c.set(title="good", xlabel="frequency (Hz)", ylabel="PSD ((mm/s^2)²/Hz)")
    d.set(title="unit alone", xlabel="time (s)", ylabel="mm/s^2")
    im = c.imshow(np.eye(2))
    fig.colorbar(im, ax=c, label="MAC (no unit)")
    found = unlabelled_axes(fig)
    plt.close(fig)
    assert found == ["bare: y axis has no label", "words: y axis 'response' gives no unit"]
    fig, ax = plt.subplots()
    ax.set(xlabel="mode", ylabel="frequency error (%)")  # a count needs no unit
    assert unlabelled_axes(fig) == []
    plt.close(fig)


def test_a_mac_is_never_rounded_up_to_one():
    from femcal.correlate import mac_text

    assert mac_text(0.9995) == "0.999" and mac_text(1.0) == "1.000"
    assert mac_text(0.7424) == "0.742" and mac_text(0.31, 2) == "0.31"
