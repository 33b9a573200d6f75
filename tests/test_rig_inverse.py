"""The pieces of the drive iteration, each against what it must do: the noise floor measured
above the band, the regularised inverse (the plain inverse where the drive is seen, nothing
where it is not), the drive directions not seen, Broyden's FRF update, the actuators'
limits, the errors in and outside the band, the relative damage, and whether a record's
ends join."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.errors import ConfigError
from femcal.rig import inverse
from femcal.rig.iterate import ends_join
from femcal.rig.limits import ActuatorLimits, check_limits, read_limits, scale_into_limits
from femcal.rig.quality import band_errors, channel_stats, relative_damage
from femcal.rig.update import broyden_update

DT = 1 / 512


def multisine(rng, rows: int, n: int, band: tuple[float, float]) -> np.ndarray:
    f = np.fft.rfftfreq(n, DT)
    S = np.where((f >= band[0]) & (f <= band[1]),
                 np.exp(2j * np.pi * rng.uniform(size=(rows, len(f)))), 0)  # fmt: skip
    x = np.fft.irfft(S, n, axis=1)
    return x / np.sqrt(np.mean(x**2, axis=1, keepdims=True))


def test_the_noise_floor_is_measured_above_the_band():
    rng = np.random.default_rng(1)
    n = 16384
    signal = multisine(rng, 3, n, (1.0, 40.0))
    fraction = np.array([0.01, 0.03, 0.1])
    noisy = signal + fraction[:, None] * rng.standard_normal(signal.shape)
    size = np.sqrt(np.mean(noisy**2, axis=1))
    f = np.fft.rfftfreq(n, DT)
    floor = inverse.noise_floor(np.fft.rfft(noisy, axis=1), f, (1.0, 40.0), n, size)
    assert floor.measured and "above the drive band" in floor.source
    assert np.allclose(floor.fraction * size, fraction, rtol=0.1)
    # variance per line of white noise of RMS s over n samples: n s^2
    assert np.allclose(floor.variance, n * fraction**2, rtol=0.2)
    given = inverse.noise_floor(np.fft.rfft(noisy, axis=1), f, (1.0, 40.0), n, size, 0.05)
    assert not given.measured and np.allclose(given.fraction, 0.05)
    # a band up to the Nyquist frequency leaves nothing to measure it on
    top = inverse.noise_floor(np.fft.rfft(noisy, axis=1), f, (1.0, 250.0), n, size)
    assert not top.measured and np.allclose(top.fraction, inverse.DEFAULT_FLOOR)


def _problem(rng, n_lines: int, n_out: int = 3, n_in: int = 3):
    H = rng.standard_normal((n_lines, n_out, n_in)) + 1j * rng.standard_normal((n_lines, n_out,
                                                                                n_in))
    D = rng.standard_normal((n_in, n_lines)) + 1j * rng.standard_normal((n_in, n_lines))
    return H, D


def test_the_inverse_is_the_plain_one_where_the_drive_stands_clear_of_the_noise():
    rng = np.random.default_rng(2)
    H, D = _problem(rng, 400)
    f = np.linspace(1.0, 40.0, 400)
    T = np.einsum("foi,if->of", H, D)
    weight = np.full(3, 1e8)  # noise variance 1e-8 per line: SNR 1e8
    prior = inverse.drive_prior(H, T, weight, f)
    pen = inverse.penalty(H, weight, prior, f)
    found = inverse.LineSolver(H, weight, pen).step(T, 0 * D)
    assert np.allclose(found, D, rtol=1e-5, atol=1e-5)
    assert inverse.unseen_directions(H, weight, pen, f) == []


def test_a_drive_direction_below_the_noise_is_held_and_named():
    """A second drive that moves the channels 1e-4 as much as the others, under noise of
    1e-2: the inverse does not amplify the noise into it, and names it in the band."""
    rng = np.random.default_rng(3)
    n_lines = 600
    f = np.linspace(1.0, 60.0, n_lines)
    H = np.tile(np.eye(3, dtype=complex), (n_lines, 1, 1))
    weak = (f > 20) & (f < 40)
    H[weak, :, 1] *= 1e-4
    D = rng.standard_normal((3, n_lines)) + 1j * rng.standard_normal((3, n_lines))
    noise = 1e-2 * (rng.standard_normal((3, n_lines)) + 1j * rng.standard_normal((3, n_lines)))
    T = np.einsum("foi,if->of", H, D) + noise
    weight = np.full(3, 1 / 2e-4)  # E|N|^2 = 2e-4
    prior = inverse.drive_prior(H, T, weight, f)
    pen = inverse.penalty(H, weight, prior, f)
    found = inverse.LineSolver(H, weight, pen).step(T, 0 * D)
    plain = np.einsum("fij,jf->if", np.linalg.inv(H), T)
    # the plain inverse blows the noise up by 1e4 there; the regularised one keeps it small
    assert np.abs(plain[1, weak]).mean() > 30 * np.abs(D[1, weak]).mean()
    assert np.abs(found[1, weak]).mean() < 0.2 * np.abs(D[1, weak]).mean()
    # and the well-seen drives stay as they were
    assert np.allclose(found[[0, 2]], D[[0, 2]], atol=0.05)
    bands = inverse.unseen_directions(H, weight, pen, f)
    assert len(bands) == 1
    band = bands[0]
    assert abs(band.low_hz - f[weak][0]) < 0.5 and abs(band.high_hz - f[weak][-1]) < 0.5
    assert band.directions == 1
    assert np.allclose(np.abs(band.pattern), [0, 1, 0], atol=1e-6)
    assert inverse.describe_pattern(band.pattern, ["a", "b", "c"]) == "+1.00 b"


def test_effort_and_roll_off_shrink_the_drive():
    rng = np.random.default_rng(4)
    H, D = _problem(rng, 200)
    H = np.eye(3) + 0.1 * H  # well conditioned: every direction seen alike
    f = np.linspace(0.5, 40.0, 200)
    T = np.einsum("foi,if->of", H, D)
    weight = np.full(3, 1e8)
    prior = inverse.drive_prior(H, T, weight, f)

    def drive(**kw) -> np.ndarray:
        pen = inverse.penalty(H, weight, prior, f, **kw)
        return inverse.LineSolver(H, weight, pen).step(T, 0 * D)

    low, high = f < 2.0, f > 20.0
    rolled = drive(roll_off_hz=5.0)
    assert np.abs(rolled[:, low]).mean() < 0.1 * np.abs(D[:, low]).mean()
    # above four times the corner, within about (1/4)^4 of the plain inverse's
    change = np.linalg.norm(rolled[:, high] - D[:, high]) / np.linalg.norm(D[:, high])
    assert change < 2 * (5.0 / 20.0) ** 4
    effort = drive(effort=1.0)
    assert np.linalg.norm(effort) < 0.8 * np.linalg.norm(D)


def test_broyden_puts_the_measured_answer_into_the_frf_and_nothing_else():
    rng = np.random.default_rng(5)
    H, dD = _problem(rng, 50)
    H_true = H + 0.3 * _problem(rng, 50)[0]
    dR = np.einsum("foi,if->of", H_true, dD)
    updated, ok = broyden_update(H, dD, dR, np.full(3, 1e6))
    assert ok.all()
    assert np.allclose(np.einsum("foi,if->of", updated, dD), dR)
    # a direction orthogonal to the step answers as before
    other = rng.standard_normal((3, 50)) + 1j * rng.standard_normal((3, 50))
    other -= dD * (np.sum(dD.conj() * other, axis=0) / np.sum(np.abs(dD) ** 2, axis=0))
    assert np.allclose(np.einsum("foi,if->of", updated, other),
                       np.einsum("foi,if->of", H, other))  # fmt: skip
    # a step whose response is lost in the noise changes nothing
    same, ok = broyden_update(H, 1e-6 * dD, dR, np.full(3, 1.0))
    assert not ok.any() and np.array_equal(same, H)


def test_limits_are_read_checked_and_kept(tmp_path):
    csv = tmp_path / "act.csv"
    csv.write_text("label,grid,x,y,z,direction,stroke,velocity,acceleration\n"
                   "A,1,0,0,0,3,2.0,,1e5\nB,2,0,0,0,3,4.0,300,\n")  # fmt: skip
    limits = read_limits(csv, ["A", "B"])
    bom = tmp_path / "bom.csv"  # as spreadsheets save it: a byte-order mark, spaces
    bom.write_bytes(b"\xef\xbb\xbf" + csv.read_text().replace(",", ", ").encode())
    assert np.array_equal(read_limits(bom, ["A", "B"]).values, limits.values)
    caps = tmp_path / "caps.csv"  # headers in capitals, a blank row as Excel writes one
    caps.write_text("Label,Stroke\nA,2\n,\nB,4\n")
    assert np.array_equal(read_limits(caps, ["A", "B"]).values[0], [2.0, 4.0])
    short = tmp_path / "short.csv"
    short.write_text("label,grid,stroke\nA,1,2\nB,2\n")
    with pytest.raises(ConfigError, match=r"short.csv:3: a short row"):
        read_limits(short, ["A", "B"])
    assert np.array_equal(limits.values, [[2.0, 4.0], [np.inf, 300.0], [1e5, np.inf]])
    t = np.arange(8192) * DT
    f0 = 4.0  # a whole number of periods: the record loops
    drive = np.vstack([1.5 * np.sin(2 * np.pi * f0 * t), 5.0 * np.sin(2 * np.pi * f0 * t)])
    check = check_limits(drive, DT, limits)
    w = 2 * np.pi * f0
    assert np.allclose(check.peak, [[1.5, 5.0], [1.5 * w, 5.0 * w], [1.5 * w**2, 5 * w**2]],
                       rtol=1e-3)  # fmt: skip
    assert check.exceeded  # B: stroke 5 of 4, velocity 126 of 300 is fine
    assert check.messages(["A", "B"], "mm") == [
        f"B: stroke {check.peak[0, 1]:.4g} mm beyond its limit 4 mm "
        f"({check.ratio[0, 1]:.2f} times)"]
    scaled, factor = scale_into_limits(drive, check)
    assert factor == pytest.approx(4.0 / check.peak[0, 1])
    assert check_limits(scaled, DT, limits).worst == pytest.approx(1.0)
    assert not check_limits(drive, DT, ActuatorLimits.none(2)).exceeded
    assert np.array_equal(limits.overridden(stroke=10.0).values[0], [10.0, 10.0])
    with pytest.raises(ValueError, match="stroke limit -1"):
        limits.overridden(stroke=-1.0)
    # no limit columns: none; a limits file must have one
    plain = tmp_path / "plain.csv"
    plain.write_text("label,grid,x,y,z,direction\nA,1,0,0,0,3\n")
    assert not read_limits(plain, ["A"]).any
    with pytest.raises(ConfigError, match="no limit column"):
        read_limits(plain, ["A"], required=True)
    bad = tmp_path / "bad.csv"
    bad.write_text("label,stroke\nA,-3\nB,1\n")
    with pytest.raises(ConfigError, match=r"bad.csv:2: actuator 'A', stroke '-3'"):
        read_limits(bad, ["A", "B"])
    with pytest.raises(ConfigError, match="no row for actuator 'C'"):
        read_limits(csv, ["A", "C"])


def test_errors_are_split_at_the_band_and_damage_scales_with_the_range():
    rng = np.random.default_rng(6)
    n = 8192
    target = multisine(rng, 2, n, (1.0, 30.0))
    t = np.arange(n) * DT
    above = 0.1 * np.sin(2 * np.pi * 100.0 * t)  # 100 Hz: outside the band, whole periods
    response = target + above
    err = band_errors(target, response, DT, (1.0, 30.0))
    assert np.allclose(err.in_band, 0, atol=1e-10)
    assert np.allclose(err.out_of_band, 0.1 / np.sqrt(2), rtol=1e-6)
    assert np.allclose(err.total, err.out_of_band)
    inside = band_errors(target, 0.9 * target, DT, (1.0, 30.0))
    assert np.allclose(inside.in_band, 0.1) and np.allclose(inside.out_of_band, 0, atol=1e-12)
    # rainflow ranges scale with the signal: Miner's sum scales as the slope's power
    assert np.allclose(relative_damage(target, 2 * target, 5.0), 32.0)
    assert np.allclose(relative_damage(target, target, 3.0), 1.0)
    with pytest.raises(ValueError, match="S-N slope"):
        relative_damage(target, target, 0.0)


def test_channel_statistics_show_a_static_offset_the_band_does_not_reproduce():
    """A target on a static offset (a preload) against a response about zero: the band's
    error does not see it, the means do, and the RMS holds the mean (sqrt(mean^2 + var))."""
    t = np.arange(4096) * DT
    wave = np.sin(2 * np.pi * 8.0 * t)
    target = np.vstack([5.0 + wave, wave])
    st = channel_stats(target, np.vstack([wave, wave]))
    assert np.allclose(band_errors(target, np.vstack([wave, wave]), DT, (1.0, 30.0)).in_band,
                       0, atol=1e-12)  # fmt: skip
    assert np.allclose(st.target_mean, [5.0, 0.0], atol=1e-12)
    assert np.allclose(st.response_mean, 0.0, atol=1e-12)
    assert np.allclose(st.target_rms, np.sqrt([25.0 + 0.5, 0.5]))
    assert st.of("target", 0) == pytest.approx({"min": 4.0, "max": 6.0, "mean": 5.0,
                                                "rms": np.sqrt(25.5)}, abs=1e-3)  # fmt: skip


def test_a_looped_record_joins_and_a_slice_does_not():
    rng = np.random.default_rng(7)
    loop = multisine(rng, 4, 8192, (0.5, 30.0))
    assert ends_join(loop)[0]
    assert ends_join(loop + 0.02 * rng.standard_normal(loop.shape))[0]
    for start, stop in ((0, 5000), (1234, 7000), (3000, 8000)):
        assert not ends_join(loop[:, start:stop])[0]
        assert not ends_join(loop[:1, start:stop])[0]


def test_the_least_squares_drive_and_each_drive_s_own_noise_variance():
    """The least-squares drive is pinv(G) W^1/2 T and the noise each drive carries the
    diagonal of pinv(G) pinv(G)^H, G = W^1/2 H, drives seen very unequally or not at all."""
    rng = np.random.default_rng(9)
    for n_out in (4, 2):  # more channels than drives, and fewer
        H, _ = _problem(rng, 3, n_out=n_out, n_in=3)
        H[:, :, 0] *= 100.0
        weight = rng.uniform(0.2, 9.0, n_out)
        T = rng.standard_normal((n_out, 3)) + 1j * rng.standard_normal((n_out, 3))
        ls, var = inverse.least_squares_drive(H, T, weight)
        for f in range(3):
            Gp = np.linalg.pinv(np.sqrt(weight)[:, None] * H[f])
            assert ls[:, f] == pytest.approx(Gp @ (np.sqrt(weight) * T[:, f]), rel=1e-6)
            assert var[:, f] == pytest.approx(np.real(np.diag(Gp @ Gp.conj().T)), rel=1e-6)
