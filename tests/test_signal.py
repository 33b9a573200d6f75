"""H1, H2 and Hv FRFs and coherences from time histories, against a system whose FRFs are known
exactly: two inputs into two outputs through digital resonators (scipy.signal.lfilter), random
inputs, noise on the outputs or on the measured inputs; the estimators' biases against the
theory (Bendat and Piersol, Random Data, 4th ed., ch. 6 and 9). Input singular values and
resampling."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal as ss

from femcal.errors import TimeDataError
from femcal.testdata.signal import (
    ESTIMATORS,
    average_cycles,
    bandpass,
    cross_spectra,
    detrend,
    frf,
    frf_from_spectra,
    h1,
    h2,
    hv,
    input_condition_number,
    input_singular_values,
    resample,
)

FS = 512.0


def resonator(f0: float, zeta: float) -> tuple[np.ndarray, np.ndarray]:
    """A digital second-order resonator (bilinear transform of 1 / (s^2 + 2 zeta w s + w^2))."""
    w = 2 * np.pi * f0
    return ss.bilinear([w**2], [1.0, 2 * zeta * w, w**2], FS)


SYSTEM = [[resonator(12.0, 0.03), resonator(40.0, 0.02)],
          [resonator(25.0, 0.05), resonator(70.0, 0.02)]]  # (output, input)
RESONANCES = [(0, 0, 12.0), (0, 1, 40.0), (1, 0, 25.0), (1, 1, 70.0)]  # (output, input, Hz)


def simulate(n: int, noise: float, seed: int = 3,
             input_noise: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Measured inputs and outputs: white unit inputs drive the system; ``noise`` (times each
    output's std) is added to the outputs, ``input_noise`` (times the inputs' std) to the
    inputs as measured, not to those that drive the system."""
    rng = np.random.default_rng(seed)
    x = rng.standard_normal((2, n))
    y = np.zeros((2, n))
    for o in range(2):
        for i in range(2):
            b, a = SYSTEM[o][i]
            y[o] += ss.lfilter(b, a, x[i])
    y += noise * y.std(axis=1, keepdims=True) * rng.standard_normal((2, n))
    x_measured = x + input_noise * x.std(axis=1, keepdims=True) * rng.standard_normal((2, n))
    return x_measured, y


def exact(f: np.ndarray) -> np.ndarray:
    H = np.zeros((2, 2, len(f)), complex)
    for o in range(2):
        for i in range(2):
            b, a = SYSTEM[o][i]
            H[o, i] = ss.freqz(b, a, worN=f, fs=FS)[1]
    return H


def all_estimates(x: np.ndarray, y: np.ndarray, segment: int) -> dict:
    """{estimator: FRFEstimate} from one set of spectra."""
    s = cross_spectra(x, y, 1 / FS, segment, full_outputs=True)
    return {name: frf_from_spectra(s, name) for name in ESTIMATORS}


def magnitude_ratios(est: dict) -> dict:
    """{estimator: |H_est| / |H_exact|} (2, 2, n_f)."""
    f = next(iter(est.values())).frequency_hz
    H = np.abs(exact(f))
    return {name: np.abs(e.H) / H for name, e in est.items()}


def at_resonances(r: np.ndarray, f: np.ndarray, half_width: float = 1.0) -> np.ndarray:
    """The values of r (2, 2, n_f) within ``half_width`` Hz of each path's own resonance."""
    return np.concatenate([r[o, i, np.abs(f - f0) < half_width] for o, i, f0 in RESONANCES])


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


def test_h1_h2_hv_match_the_exact_frfs_without_noise():
    x, y = simulate(2**17, noise=0.0)
    est = all_estimates(x, y, segment=2048)
    f = est["H1"].frequency_hz
    band = (f > 2) & (f < 100)
    H = exact(f[band])
    for name, e in est.items():
        assert e.estimator == name
        err = np.abs(e.H[:, :, band] - H) / np.abs(H)
        assert np.median(err) < 0.01, name
        # the coherences are the data's, whichever the estimator
        np.testing.assert_array_equal(e.multiple_coherence, est["H1"].multiple_coherence)
        np.testing.assert_array_equal(e.coherence, est["H1"].coherence)
    # the dispatcher (any case) and the named functions give the same
    for name, fn in (("h1", h1), ("H2", h2), ("hV", hv)):
        np.testing.assert_allclose(frf(x, y, 1 / FS, 2048, estimator=name).H,
                                   fn(x, y, 1 / FS, 2048).H, rtol=1e-12)
    np.testing.assert_allclose(h2(x, y, 1 / FS, 2048).H, est["H2"].H, rtol=1e-12)


def test_output_noise_leaves_h1_unbiased_and_biases_h2_high():
    # noise of 30 % of each output's std on the outputs only
    x, y = simulate(2**17, noise=0.3, seed=7)
    est = all_estimates(x, y, segment=4096)
    f = est["H1"].frequency_hz
    r = magnitude_ratios(est)
    # at the resonances the coherence is high and H1 is right
    assert np.median(np.abs(at_resonances(r["H1"], f) - 1)) < 0.03
    # where the outputs' coherence is lowish, H2 = H + G_nn G_xy^-1 is too large (for one
    # input |H2| = |H| / coherence), H1 is not, Hv lies between
    coh = est["H1"].multiple_coherence
    low = (coh > 0.2) & (coh < 0.8) & ((f > 2) & (f < 100))[None, :]  # (output, line)
    assert low.sum() > 100
    median = {name: np.median(np.concatenate([ratio[o][:, low[o]].ravel() for o in range(2)]))
              for name, ratio in r.items()}
    assert 0.9 < median["H1"] < 1.1
    assert median["H2"] > 1.25
    assert median["H1"] < median["Hv"] < median["H2"]


def test_input_noise_biases_h1_low_and_leaves_h2_unbiased():
    # noise of 30 % of the inputs' std on the inputs as measured only
    x, y = simulate(2**17, noise=0.0, seed=5, input_noise=0.3)
    est = all_estimates(x, y, segment=4096)
    f = est["H1"].frequency_hz
    r = magnitude_ratios(est)
    band = (f > 2) & (f < 100)
    # independent white inputs with white noise: H1 = H G_xx (G_xx + G_mm)^-1 = H / (1 + 0.3^2)
    assert np.median(r["H1"][:, :, band]) == pytest.approx(1 / (1 + 0.3**2), abs=0.02)
    assert np.median(at_resonances(r["H1"], f)) == pytest.approx(1 / (1 + 0.3**2), abs=0.03)
    # H2 (square MIMO: as many outputs as inputs) does not see the input noise (its scatter,
    # a few per cent with 63 averages at a coherence of 0.92, is not bias)
    assert abs(np.median(at_resonances(r["H2"], f)) - 1) < 0.02
    assert abs(np.median(r["H2"][:, :, band]) - 1) < 0.02
    assert np.median(r["Hv"][:, :, band]) > np.median(r["H1"][:, :, band])


def test_single_input_h2_is_gyy_over_gxy_per_output_and_hv_lies_between_h1_and_h2():
    # one measured input; the other drive acts as noise on both outputs
    x, y = simulate(2**16, noise=0.1)
    s = cross_spectra(x[:1], y, 1 / FS, 1024)
    e1, e2, ev = (frf_from_spectra(s, name) for name in ESTIMATORS)
    H1, H2, Hv = e1.H[:, 0], e2.H[:, 0], ev.H[:, 0]  # (output, line)
    np.testing.assert_allclose(H2, (s.Gyy / np.conj(s.Gyx[:, :, 0])).T, rtol=1e-12)
    # H1 / H2 is the ordinary coherence (Bendat and Piersol)
    np.testing.assert_allclose(H1 / H2, e1.coherence[:, 0], rtol=1e-9, atol=1e-12)
    # Hv has their phase and a magnitude between theirs
    assert np.all(np.abs(H1) <= np.abs(Hv) * (1 + 1e-9))
    assert np.all(np.abs(Hv) <= np.abs(H2) * (1 + 1e-9))
    np.testing.assert_allclose(np.angle(Hv / H1), 0.0, atol=1e-9)
    # the same through the named function, which needs no full output matrix with one input
    np.testing.assert_allclose(h2(x[:1], y, 1 / FS, 1024).H[:, 0], H2, rtol=1e-12)


def test_lines_without_excitation_give_nan_for_every_estimator():
    rng = np.random.default_rng(2)
    y = rng.standard_normal((2, 4096))
    for name in ESTIMATORS:
        est = frf(np.zeros((2, 4096)), y, 1 / FS, 256, estimator=name)
        assert np.isnan(est.H).all(), name


def test_input_singular_values_tell_independent_drives_from_dependent_ones():
    rng = np.random.default_rng(11)
    a = rng.standard_normal((2, 2**16))
    s = cross_spectra(a, a[:1], 1 / FS, 1024)
    f = s.frequency_hz
    inner = (f > 1) & (f < 250)
    sv = input_singular_values(s)
    assert sv.shape == (len(f), 2)
    assert np.all(sv[:, 0] >= sv[:, 1])
    assert np.median(sv[inner, 1] / sv[inner, 0]) > 0.5
    # the largest is the total power when the smallest is nought; here, about each input's
    assert np.median(sv[inner, 0]) == pytest.approx(1 / (FS / 2), rel=0.3)
    # a second drive that is 0.99 times the first plus a little noise
    dependent = np.vstack([a[0], 0.99 * a[0] + 1e-3 * a[1]])
    s = cross_spectra(dependent, a[:1], 1 / FS, 1024)
    sv = input_singular_values(s)
    assert np.max(sv[inner, 1] / sv[inner, 0]) < 1e-2
    np.testing.assert_allclose(input_condition_number(s), sv[:, 0] / sv[:, 1])
    assert np.min(input_condition_number(s)[inner]) > 100


def test_resample_keeps_a_sine_and_filters_out_what_would_alias():
    t = np.arange(2**16) / FS
    x = np.vstack([np.sin(2 * np.pi * 20.0 * t + 0.3), 0.5 * np.cos(2 * np.pi * 61.3 * t - 1.0)])
    y, dt = resample(x, 1 / FS, 1 / 256.0)
    assert dt == 1 / 256.0
    assert y.shape == (2, 2**15)
    t2 = np.arange(y.shape[1]) * dt
    expected = np.vstack([np.sin(2 * np.pi * 20.0 * t2 + 0.3),
                          0.5 * np.cos(2 * np.pi * 61.3 * t2 - 1.0)])
    middle = slice(100, -100)  # away from the ends
    np.testing.assert_allclose(y[:, middle], expected[:, middle], atol=1e-3)
    # a tone above the new Nyquist frequency (128 Hz) is filtered out, not folded to 56 Hz
    z, _ = resample(np.sin(2 * np.pi * 200.0 * t), 1 / FS, 1 / 256.0)
    assert np.abs(z[0, middle]).max() < 1e-3
    # 512 -> 384 Hz is 3/4
    w, dt = resample(x[0], 1 / FS, 1 / 384.0)
    assert dt == pytest.approx(1 / 384.0, rel=1e-12)
    assert w.shape == (1, 3 * 2**16 // 4)
    t3 = np.arange(w.shape[1]) * dt
    np.testing.assert_allclose(w[0, middle], np.sin(2 * np.pi * 20.0 * t3 + 0.3)[middle], atol=1e-3)


def test_bad_estimators_and_resampling_ratios_are_errors():
    x = np.zeros((2, 100))
    with pytest.raises(TimeDataError, match="FRF estimator 'H3': expected one of H1, H2, Hv"):
        frf(x, x, 0.01, 20, estimator="H3")
    with pytest.raises(TimeDataError, match="H2 of 2 inputs and 3 outputs"):
        h2(x, np.zeros((3, 100)), 0.01, 20)
    with pytest.raises(TimeDataError, match="full_outputs=True"):
        frf_from_spectra(cross_spectra(x, x, 0.01, 20), "H2")
    with pytest.raises(TimeDataError, match=r"rate ratio of 3\.14159.*up to 1000"):
        resample(x, 1 / FS, 1 / (FS * np.pi))
    with pytest.raises(TimeDataError, match="rate ratio of 1001"):
        resample(x, 1 / FS, 1 / (FS * 1001))
    with pytest.raises(TimeDataError, match="expected positive, finite steps"):
        resample(x, 1 / FS, 0.0)
    with pytest.raises(TimeDataError, match="expected positive, finite steps"):
        resample(x, -1.0, 1 / FS)
    with pytest.raises(TimeDataError, match="NaN or infinite"):
        resample(np.full((1, 100), np.nan), 1 / FS, 2 / FS)
