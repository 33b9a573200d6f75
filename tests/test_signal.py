"""H1 FRFs and coherences from time histories, against a system whose FRFs are known exactly:
two inputs into two outputs through digital resonators (scipy.signal.lfilter), random inputs,
output noise."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as ss

from femcal.errors import TimeDataError
from femcal.testdata.signal import average_cycles, bandpass, cross_spectra, detrend, h1

FS = 512.0


def resonator(f0: float, zeta: float) -> tuple[np.ndarray, np.ndarray]:
    """A digital second-order resonator (bilinear transform of 1 / (s^2 + 2 zeta w s + w^2))."""
    w = 2 * np.pi * f0
    return ss.bilinear([w**2], [1.0, 2 * zeta * w, w**2], FS)


SYSTEM = [[resonator(12.0, 0.03), resonator(40.0, 0.02)],
          [resonator(25.0, 0.05), resonator(70.0, 0.02)]]  # (output, input)


def simulate(n: int, noise: float, seed: int = 3) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((2, n))
    y = np.zeros((2, n))
    for o in range(2):
        for i in range(2):
            b, a = SYSTEM[o][i]
            y[o] += ss.lfilter(b, a, x[i])
    y += noise * y.std(axis=1, keepdims=True) * rng.standard_normal((2, n))
    return x, y


def exact(f: np.ndarray) -> np.ndarray:
    H = np.zeros((2, 2, len(f)), complex)
    for o in range(2):
        for i in range(2):
            b, a = SYSTEM[o][i]
            H[o, i] = ss.freqz(b, a, worN=f, fs=FS)[1]
    return H


def test_h1_of_a_two_input_system_matches_its_exact_frfs():
    x, y = simulate(2**18, noise=0.05)
    est = h1(x, y, 1 / FS, segment=2048)
    # where the inputs explain the outputs (the noise floor lies above the resonators'
    # high-frequency tails, where the coherence falls, as it should)
    f = est.frequency_hz
    band = (f > 2) & (f < 250) & (est.multiple_coherence.min(axis=0) > 0.95)
    assert band.sum() > 200  # 2 to about 100 Hz
    H = exact(f[band])
    err = np.abs(est.H[:, :, band] - H) / np.abs(H)
    assert np.median(err) < 0.02
    assert np.median(est.multiple_coherence[:, (f > 150) & (f < 250)]) < 0.5  # noise there
    # with two independent inputs each explains only its own share
    assert np.all(np.median(est.coherence[:, :, band], axis=2) < 0.99)


def test_welch_density_of_white_noise_is_its_variance_over_half_the_rate():
    rng = np.random.default_rng(1)
    x = 2.0 * rng.standard_normal((1, 2**17))
    s = cross_spectra(x, x, 1 / FS, segment=1024)
    inner = (s.frequency_hz > 1) & (s.frequency_hz < 250)
    assert np.mean(s.Gxx[inner, 0, 0].real) == pytest.approx(4.0 / (FS / 2), rel=0.02)
    assert s.segments == 2 * 2**17 // 1024 - 1


def test_bad_arguments_are_errors():
    x = np.zeros((1, 100))
    with pytest.raises(TimeDataError, match="segment of 200 samples: expected 8 to the 100"):
        h1(x, x, 0.01, 200)
    with pytest.raises(TimeDataError, match="inputs of 100 samples, outputs of 50"):
        h1(x, x[:, :50], 0.01, 20)
    with pytest.raises(TimeDataError, match=r"overlap 1\.0"):
        h1(x, x, 0.01, 20, overlap=1.0)


def test_cycle_averaging_keeps_the_cycle_and_divides_the_noise():
    rng = np.random.default_rng(5)
    period, cycles = 256, 30
    cycle = rng.standard_normal((2, period))
    record = np.tile(cycle, cycles) + 0.5 * rng.standard_normal((2, period * cycles))
    mean = average_cycles(record, period)
    residual = (mean - cycle).std()
    assert residual == pytest.approx(0.5 / np.sqrt(cycles), rel=0.1)
    np.testing.assert_allclose(average_cycles(np.tile(cycle, cycles), period), cycle)
    with pytest.raises(TimeDataError, match="7680 samples are not whole cycles of 250"):
        average_cycles(record, 250)


def test_detrend_removes_a_line_and_bandpass_passes_the_band_with_zero_phase():
    t = np.arange(8192) / FS
    inband = np.sin(2 * np.pi * 10.0 * t + 0.3)
    record = inband + 0.2 * np.sin(2 * np.pi * 150.0 * t) + 3.0 + 0.5 * t
    clean = bandpass(detrend(record), 1 / FS, 0.5, 30.0, order=200)
    middle = slice(1000, -1000)  # away from the ends' transients
    np.testing.assert_allclose(clean[0, middle], inband[middle], atol=0.02)  # no phase lag
    assert np.abs(detrend(3.0 + 0.5 * t)).max() < 1e-9
    with pytest.raises(TimeDataError, match=r"band 0\.5-300 Hz"):
        bandpass(record, 1 / FS, 0.5, 300.0)
