"""System identification: FRFs made from known modal models (with modes outside the band)
give their poles and shapes back; noise, broken channels, damping equalisation, the
stabilisation diagram, the building blocks against their definitions."""

from __future__ import annotations

import itertools
import re
from pathlib import Path

import numpy as np
import pytest

from femcal.correlate.shapes import mac
from femcal.identify import (
    Settings,
    equalize_damping,
    fit_fixed_poles,
    frequency_response,
    identify,
    model_of_order,
    plscf,
    stable_columns,
    subspace,
    subspace_basis,
)
from femcal.identify.lsq import Resolvent, cost, response
from femcal.response.statespace import modal_to_poles, poles_to_modal
from femcal.testdata.data import FRFData, FRFError

FN = np.array([12.0, 21.0, 33.0, 47.0, 52.0, 80.0, 130.0, 200.0])  # Hz
ZETA = np.array([0.01, 0.02, 0.015, 0.01, 0.012, 0.02, 0.01, 0.01])
BAND = (15.0, 100.0)
IN_BAND = (BAND[0] < FN) & (BAND[1] > FN)  # 21, 33, 47, 52, 80 Hz


def modal_set(*, p=12, m=2, noise=0.0, seed=0, f=None):
    """Accelerance of a proportionally damped modal model: real shapes phi (p, k) and
    participations L (m, k); 2 % noise is relative to each value."""
    rng = np.random.default_rng(seed)
    f = np.arange(1.0, 160.0, 0.1) if f is None else f
    phi = rng.normal(size=(p, len(FN)))
    L = rng.normal(size=(m, len(FN)))
    w, wn = 2 * np.pi * f, 2 * np.pi * FN
    q = -(w**2) / (wn[:, None] ** 2 - w**2 + 2j * (ZETA * wn)[:, None] * w)
    H = np.einsum("pk,mk,kf->pmf", phi, L, q)
    H = H + noise * np.abs(H) * (rng.normal(size=H.shape) + 1j * rng.normal(size=H.shape)) / 2**0.5
    data = FRFData.from_labels(f, H, [f"{i + 1}:+Z" for i in range(p)],
                               [f"{100 + i}:+Y" for i in range(m)], "accelerance", "mm/s^2/N")  # fmt: skip
    return data, phi


@pytest.mark.parametrize("splits", [(), (40.0,)])
def test_noise_free_poles_and_shapes_come_back(splits):
    data, phi = modal_set()
    model = identify(data, BAND, splits=splits)
    assert len(model.frequency_hz) == IN_BAND.sum()
    np.testing.assert_allclose(model.frequency_hz, FN[IN_BAND], rtol=1e-4)
    np.testing.assert_allclose(model.damping_ratio, ZETA[IN_BAND], rtol=1e-4)
    assert np.diag(mac(model.shapes, phi[:, IN_BAND])).min() > 0.9999
    # the modes at 12, 130 and 200 Hz act in the band through the residual poles and D,
    # which stand for them to a few parts in a thousand
    assert model.fit_error.max() < 0.005 and not model.suspect.any()
    sel = (data.frequency_hz >= BAND[0]) & (data.frequency_hz <= BAND[1])
    Hm = model.frf(data.frequency_hz[sel]).H
    assert np.linalg.norm(Hm - data.H[:, :, sel]) < 0.005 * np.linalg.norm(data.H[:, :, sel])
    # shapes normalised to a largest component of 1; shape x participation is the residue
    assert np.allclose(np.abs(model.shapes).max(axis=0), 1.0)
    assert np.allclose(model.shapes[np.argmax(np.abs(model.shapes), axis=0), range(5)], 1.0)


def test_two_percent_noise_within_half_a_percent_and_twenty_percent_damping():
    for seed in (1, 2, 3):
        data, phi = modal_set(noise=0.02, seed=seed, p=24)
        model = identify(data, BAND, splits=(40.0,))
        assert len(model.frequency_hz) == IN_BAND.sum(), seed
        assert np.abs(model.frequency_hz / FN[IN_BAND] - 1).max() < 0.005
        assert np.abs(model.damping_ratio / ZETA[IN_BAND] - 1).max() < 0.2
        assert np.diag(mac(model.shapes, phi[:, IN_BAND])).min() > 0.99
        assert 0.01 < np.median(model.fit_error) < 0.04  # the noise level


def test_broken_channels_are_flagged_and_do_not_spoil_the_poles():
    data, _ = modal_set(noise=0.02, seed=4, p=24)
    H = data.H.copy()
    rng = np.random.default_rng(5)
    H[5] = np.abs(H[5]).mean() * (rng.normal(size=H[5].shape) + 1j * rng.normal(size=H[5].shape))
    H[13] = np.roll(H[13], 50, axis=-1)  # a channel from another measurement
    broken = FRFData(data.frequency_hz, H, data.outputs, data.inputs, data.quantity, data.units)
    lines = []
    model = identify(broken, BAND, progress=lines.append)
    assert list(np.flatnonzero(model.suspect)) == [5, 13]
    assert model.fit_error[[5, 13]].min() > 0.5
    assert any("channels 6:+Z, 14:+Z are not consistent" in line for line in lines)
    assert np.abs(model.frequency_hz / FN[IN_BAND] - 1).max() < 0.005


def test_damping_equalisation_keeps_damped_frequencies_and_residues():
    data, _ = modal_set()
    model = identify(data, BAND)
    eq = equalize_damping(model, 0.01)
    np.testing.assert_allclose(eq.damping_ratio, 0.01, rtol=1e-12)
    np.testing.assert_allclose(eq.poles.imag, model.poles.imag, rtol=1e-12)
    # every physical pole of the system carries zeta0 now; the residual poles are kept
    lam_all = np.linalg.eigvals(eq.system.A)
    _, z_all = poles_to_modal(lam_all)
    res_lam = np.linalg.eigvals(model.system.A[model.residual_states][:, model.residual_states])
    is_res = np.array([np.isclose(res_lam, x, rtol=1e-9).any() for x in lam_all])
    np.testing.assert_allclose(z_all[~is_res], 0.01, rtol=1e-9)
    assert is_res.sum() == model.residual_states.sum()
    # the equalised FRF is the residues over the new poles plus the original model's
    # residual states and feedthrough, unchanged
    f = np.linspace(16, 99, 57)
    s = 2j * np.pi * f
    k = len(model.poles)
    res = np.einsum("pk,mk->kpm", model.shapes, model.participation)
    lam = eq.poles
    phys = np.einsum("kpm,kf->pmf", res, 1 / (s[None] - lam[:, None])) + np.einsum(
        "kpm,kf->pmf", res.conj(), 1 / (s[None] - lam.conj()[:, None]))
    rest = model.system
    n_phys = 2 * k
    from femcal.response.statespace import StateSpace

    tail = StateSpace(rest.A[n_phys:, n_phys:], rest.B[n_phys:], rest.C[:, n_phys:], rest.D)
    np.testing.assert_allclose(eq.frf(f).H, phys + frequency_response(tail, f), rtol=1e-9,
                               atol=1e-9 * np.abs(phys).max())  # fmt: skip
    # and with zeta0 equal to a mode's own damping nothing changes near that mode
    same = equalize_damping(model, float(model.damping_ratio[0]))
    near = np.linspace(0.98, 1.02, 5) * model.frequency_hz[0]
    first = model.frf(near).H
    assert np.abs(same.frf(near).H - first).max() < 0.05 * np.abs(first).max()
    with pytest.raises(ValueError, match="expected 0 <= zeta0 < 1"):
        equalize_damping(model, 1.5)


@pytest.mark.parametrize("method", ["plscf", "subspace"])
def test_stabilisation_diagram_finds_the_modes(method):
    data, _ = modal_set(noise=0.01, seed=7)
    sel = (data.frequency_hz >= BAND[0]) & (data.frequency_hz <= BAND[1])
    f, H = data.frequency_hz[sel], data.H[:, :, sel]
    if method == "plscf":
        raw = plscf.diagram_poles(f, H, range(1, 21))
    else:
        raw, _ = subspace.diagram_poles(f, H, range(2, 41, 2))
    d = stable_columns(raw, BAND, method, 0.1)
    # 1 % noise: every mode of the band, each once, within a tenth of a percent
    np.testing.assert_allclose(d.modes_hz, FN[IN_BAND], rtol=1e-3)
    # a mode's column is stable in most of its orders, and every chosen pole's order marks
    # it as the mode it joined
    assert (d.support >= 0.5 * d.n_orders_seen).all()
    for k in range(len(d.modes)):
        joined = [op.frequency_hz[op.mode == k] for op in d.orders]
        assert sum(len(x) for x in joined) == d.support[k]
        assert np.all(np.abs(np.concatenate(joined) / d.modes_hz[k] - 1) < 0.01)


def test_subspace_recovers_an_exact_state_space_model():
    # a random stable continuous model of order 6, no feedthrough
    rng = np.random.default_rng(11)
    poles = modal_to_poles(np.array([5.0, 9.0, 14.0]), np.array([0.02, 0.05, 0.01]))
    f = np.linspace(2.0, 20.0, 200)
    s = 2j * np.pi * f
    c = rng.normal(size=(3, 4)) + 1j * rng.normal(size=(3, 4))
    b = rng.normal(size=(3, 2)) + 1j * rng.normal(size=(3, 2))
    res = np.einsum("kp,km->kpm", c, b)  # rank one: a state pair per pole pair
    H = (np.einsum("kpm,kf->pmf", res, 1 / (s[None] - poles[:, None]))
         + np.einsum("kpm,kf->pmf", res.conj(), 1 / (s[None] - poles.conj()[:, None])))  # fmt: skip
    A, _ = model_of_order(subspace_basis(f, H, 5), 6)
    got = np.sort_complex(np.linalg.eigvals(A))
    want = np.sort_complex(np.concatenate([poles, poles.conj()]))
    np.testing.assert_allclose(got, want, rtol=1e-9)
    # the fixed-pole least squares gives the model back exactly
    model, _ = fit_fixed_poles(s, H, poles, feedthrough=False)
    assert np.linalg.norm(response(model, s) - H) < 1e-9 * np.linalg.norm(H)
    # with rank-two residues (each pole seen differently from the two inputs) one state
    # pair per pole cannot fit; the fit is then the least-squares optimum in B and in C, D
    res2 = res + np.einsum("kp,km->kpm", c[:, ::-1], b[:, ::-1])
    H2 = (np.einsum("kpm,kf->pmf", res2, 1 / (s[None] - poles[:, None]))
          + np.einsum("kpm,kf->pmf", res2.conj(), 1 / (s[None] - poles.conj()[:, None])))  # fmt: skip
    model, history = fit_fixed_poles(s, H2, poles, feedthrough=False)
    assert all(b <= a * (1 + 1e-9) for a, b in itertools.pairwise(history))
    R = Resolvent(model.A, s)
    best = cost(R, model.B, model.C, model.D, H2)
    assert best > 1e-3 * np.vdot(H2, H2).real
    for _ in range(5):
        dB = 1e-3 * rng.normal(size=model.B.shape)
        dC = 1e-3 * rng.normal(size=model.C.shape)
        assert cost(R, model.B + dB, model.C, model.D, H2) > best
        assert cost(R, model.B, model.C + dC, model.D, H2) > best


def test_bad_arguments_are_refused():
    data, _ = modal_set()
    with pytest.raises(ValueError, match="outside the data"):
        identify(data, (10.0, 500.0))
    with pytest.raises(ValueError, match="must lie inside the band"):
        identify(data, BAND, splits=(120.0,))
    with pytest.raises(ValueError, match="2 orders for 3 parts"):
        identify(data, BAND, splits=(30.0, 60.0), orders=[4, 4])
    with pytest.raises(ValueError, match="order 999 is outside"):
        identify(data, BAND, orders=999, settings=Settings())


def test_cli_writes_the_model_summary_and_pictures(tmp_path, capsys):
    import json

    from femcal.cli import main
    from femcal.io.identified import read_model
    from femcal.testdata.formats.uff import write_uff

    data, _ = modal_set(noise=0.01, seed=8)
    H = data.H.copy()
    H[3] = np.roll(H[3], 40, axis=-1)  # a channel from another measurement
    src = write_uff(tmp_path / "test.uff",
                    FRFData(data.frequency_hz, H, data.outputs, data.inputs, data.quantity,
                            data.units))  # fmt: skip
    out = tmp_path / "out"
    rc = main(["identify", str(src), "--band", "15", "100", "--split", "40",
               "--json", str(tmp_path / "id.json"), "--out", str(out)])  # fmt: skip
    assert rc == 0
    printed = capsys.readouterr().out
    assert "doubt: Channel 4:3 is suspect: the identified model misses its FRFs" in printed
    assert "verdict: " in printed and "1 suspect channel;" in printed
    summary = json.loads((tmp_path / "id.json").read_text())
    got = [p["frequency_hz"] for p in summary["poles"]]
    np.testing.assert_allclose(got, FN[IN_BAND], rtol=0.005)
    assert all(0 < p["damping_ratio"] < 0.05 for p in summary["poles"])
    chans = {c["label"]: c for c in summary["channels"]}
    assert chans["4:3"]["suspect"] and chans["4:3"]["fit_error"] > 0.5
    assert summary["suspect_channels"] == ["4:3"]
    for name in ("model.npz", "identify.json", "frf_model.npz", "overlay.png",
                 "stabilization_part1.png", "stabilization_part2.png"):  # fmt: skip
        assert (out / name).stat().st_size > 0, name
    # the page: its verdict first, the suspect channel doubted there, every picture inside
    from femcal.io.html import outside_references

    page = (out / "identification.html").read_text()
    assert page.index("<h2>Verdict</h2>") < page.index("id='modes'") < page.index(
        "id='figures'") < page.index("id='provenance'")
    doubts = page[page.index("What to doubt"):page.index("</section>")]
    assert "Channel 4:3 is suspect" in doubts
    assert len(re.findall(r"<img src='data:image/png;base64,", page)) == 4  # 2 + 2 diagrams
    assert outside_references(page) == []
    back = read_model(out / "model.npz")
    np.testing.assert_allclose(back.frequency_hz, got, rtol=1e-12)
    clean, _ = modal_set(seed=8)  # the same model without noise (noise is drawn last)
    sel = (clean.frequency_hz >= 20) & (clean.frequency_hz <= 90)
    ok = ~back.suspect
    Hm = back.frf(clean.frequency_hz[sel]).H[ok]
    H0 = clean.H[ok][:, :, sel]
    assert np.linalg.norm(Hm - H0) < 0.02 * np.linalg.norm(H0)


def test_cli_reports_bad_input(tmp_path, capsys):
    from femcal.cli import main

    assert main(["identify", str(tmp_path / "none.npz"), "--band", "1", "2"]) == 2
    assert "No such file or directory" in capsys.readouterr().err
    data, _ = modal_set()
    from femcal.testdata.formats.npz import write_npz

    src = write_npz(tmp_path / "d.npz", data)
    assert main(["identify", str(src), "--band", "15", "500"]) == 2
    assert "outside the data" in capsys.readouterr().err
    assert main(["identify", str(src), "--band", "15", "100", "--units", "g/N"]) == 0


# ----------------------------------------------------------------------------- bad data


def with_h(data: FRFData, H: np.ndarray, f: np.ndarray | None = None) -> FRFData:
    return FRFData(data.frequency_hz if f is None else f, H, data.outputs, data.inputs,
                   data.quantity, data.units)  # fmt: skip


def test_dead_real_or_nonfinite_channels_are_refused_by_name():
    data, _ = modal_set(p=4)
    H = data.H.copy()
    H[2] = 0  # one dead sensor
    with pytest.raises(FRFError, match=r"^output 3:\+Z is zero at every input and frequency "
                       "in the band 15-100 Hz: a dead or unconnected sensor"):  # fmt: skip
        identify(with_h(data, H), BAND)
    with pytest.raises(FRFError, match=r"^outputs 1:\+Z, 2:\+Z, 3:\+Z, 4:\+Z \(every output\) "
                       "are zero"):  # fmt: skip
        identify(with_h(data, 0 * H), BAND)
    H = data.H.copy()
    H[:, 1] = 0
    with pytest.raises(FRFError, match=r"^input 101:\+Y is zero at every output"):
        identify(with_h(data, H), BAND)
    H = data.H.copy()
    H[1] = H[1].real  # magnitudes or real parts only
    with pytest.raises(FRFError, match=r"^output 2:\+Z is real \(no imaginary part\) in the "
                       "band 15-100 Hz: identification needs complex FRFs"):  # fmt: skip
        identify(with_h(data, H), BAND)
    H = data.H.copy()
    k = int(np.searchsorted(data.frequency_hz, 50.0))
    H[3, 0, k] = np.nan  # e.g. a pair not measured (assemble_runs with allow_missing)
    with pytest.raises(FRFError, match=r"^output 4:\+Z / input 100:\+Y at 50 Hz: H is "
                       r"\(nan\+0j\) \(1 such value in the band 15-100 Hz\)"):  # fmt: skip
        identify(with_h(data, H), BAND)
    identify(with_h(data, H), (15.0, 45.0), orders=10)  # outside the band it is not used
    H = data.H.copy()
    H[0, 1, k] = 1e300  # beyond any unit: the channel scaling would overflow
    with pytest.raises(FRFError, match=r"output 1:\+Z / input 101:\+Y at 50 Hz: H is "
                       r"\(1e\+300\+0j\).*magnitude 1e-100 to 1e\+100"):  # fmt: skip
        identify(with_h(data, H), BAND)


def test_bands_the_numbers_cannot_hold_and_too_few_frequencies_are_refused():
    data, _ = modal_set(p=3)
    f = data.frequency_hz.copy()
    f[0] = 1e-320
    with pytest.raises(FRFError, match=r"band [\d.]+e-321-100 Hz: expected an upper edge at most "
                       "1e\\+12 times the lower"):  # fmt: skip
        identify(with_h(data, data.H, f), (1e-320, 100.0))
    f = data.frequency_hz.copy()
    f[-1] = 1e308
    with pytest.raises(FRFError, match=r"band 15-1e\+308 Hz: expected an upper edge of at most "
                       "1e\\+09 Hz"):  # fmt: skip
        identify(with_h(data, data.H, f), (15.0, 1e308))
    # one output, one input, four frequencies: not even order 2 (the fuzzer's case 4:7441)
    few = FRFData(data.frequency_hz[:4], data.H[:1, :1, :4], data.outputs[:1], data.inputs[:1],
                  data.quantity)  # fmt: skip
    band = (float(few.frequency_hz[0]), float(few.frequency_hz[-1]))
    for method in ("plscf", "subspace"):
        with pytest.raises(FRFError, match=r"part 1-1.3 Hz: 4 frequencies and 1 channel\(s\) "
                           rf"allow \d {method} order\(s\) \(up to \d\); a stabilisation "
                           "diagram needs 4 at least"):
            identify(few, band, settings=Settings(method=method))
    with pytest.raises(FRFError, match=r"order 4 is outside 1\.\.\d for part 1-1\.3 Hz"):
        identify(few, band, orders=4)


@pytest.mark.parametrize(("setting", "value", "expected"), [
    ("gamma", 1.0, "a number above 1"), ("gamma", 0.0, "a number above 1"),
    ("gamma", -1.0, "a number above 1"), ("gamma", float("nan"), "a number above 1"),
    ("beta", 1.2, "a number above gamma"), ("beta", float("inf"), "a number above gamma"),
    ("residual_damping", 0.0, "between 0 and 1"), ("zeta_max", 2.0, r"in \(0, 1\]"),
    ("max_order", 1, "from 2 to 200"), ("max_iter", 0, "at least 1"),
])  # fmt: skip
def test_settings_that_make_no_sense_are_refused(setting, value, expected):
    with pytest.raises(ValueError, match=rf"identification setting {setting} = .*: expected .*"
                       f"{expected}"):  # fmt: skip
        Settings(**{setting: value})


@pytest.mark.parametrize(("args", "expected"), [
    (["--gamma", "0"], "--gamma 0: expected a number above 1"),
    (["--gamma", "-1"], "--gamma -1: expected a number above 1"),
    (["--gamma", "1"], "--gamma 1: expected a number above 1"),
    (["--beta", "1.2"], r"--beta 1.2: expected a number above --gamma \(1.43\)"),
    (["--band", "50", "15"], "--band 50 15: expected 0 <= F1 < F2"),
    (["--band", "-5", "50"], "--band -5 50: expected 0 <= F1 < F2"),
    (["--band", "15", "inf"], "--band 15 inf: expected 0 <= F1 < F2"),
    (["--split", "nan"], "--split nan: expected a frequency inside the band 15-100 Hz"),
    (["--max-order", "1"], "--max-order 1: expected a whole number from 2 to 200"),
    (["--order", "4", "4"], "--order: 2 orders without --split"),
    (["--order", "4", "4", "--split", "30", "60"], "--order: 2 orders for 3 parts"),
])  # fmt: skip
def test_cli_refuses_bad_options_in_one_line_before_reading(tmp_path, capsys, args, expected):
    from femcal.cli import main

    missing = tmp_path / "not-read.npz"  # checked before the file is read
    argv = ["identify", str(missing), "--band", "15", "100"]
    if args[0] == "--band":
        argv = argv[:3] + args[1:]
    else:
        argv += args
    assert main(argv) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("femcal identify: ")
    assert re.search(expected, err[0]), err[0]


def test_cli_refuses_an_out_that_is_a_file_and_bad_files_by_name(tmp_path, capsys):
    from femcal.cli import main
    from femcal.testdata.formats.npz import write_npz

    data, _ = modal_set(p=3)
    src = write_npz(tmp_path / "d.npz", data)
    (tmp_path / "taken").write_text("")
    assert main(["identify", str(src), "--band", "15", "100", "--out",
                 str(tmp_path / "taken")]) == 2  # fmt: skip
    assert "--out " in capsys.readouterr().err and (tmp_path / "taken").read_text() == ""
    assert main(["identify", str(src), "--band", "15", "100", "--json", str(tmp_path)]) == 2
    assert "is a directory; expected a file name" in capsys.readouterr().err
    assert main(["identify", str(src), "--band", "15", "100", "--json",
                 str(tmp_path / "taken" / "id.json")]) == 2  # fmt: skip
    assert f"{tmp_path / 'taken'} is a file, not a directory" in capsys.readouterr().err
    H = data.H.copy()
    H[1] = 0
    dead = write_npz(tmp_path / "dead.npz", with_h(data, H))
    assert main(["identify", str(dead), "--band", "15", "100"]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith(f"femcal identify: {dead}: output 2:+Z is zero")
    f = data.frequency_hz.copy()
    f[7] = np.nan
    np.savez(tmp_path / "nanf.npz", frequency_hz=f, H=data.H,
             output_labels=np.array([c.label for c in data.outputs]),
             input_labels=np.array([c.label for c in data.inputs]),
             quantity=np.array("accelerance"))  # fmt: skip
    assert main(["identify", str(tmp_path / "nanf.npz"), "--band", "15", "100"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"femcal identify: {tmp_path / 'nanf.npz'}: frequency_hz: frequency 8 of "
                   f"{len(f)} is nan; expected finite, non-negative, strictly increasing "
                   "frequencies in Hz"]


@pytest.mark.parametrize("method", ["plscf", "subspace"])
def test_a_plate_with_twelve_modes_in_the_band_gives_all_twelve_with_only_the_band(
        tmp_path, method):  # fmt: skip
    """14 x 2 noise-free accelerances of the calibration tests' plate, 12 modes in 8-420 Hz
    (two 11 Hz apart at the top): with only the band, every mode within 0.05 % and the
    model's FRFs within 1 % of the data, no warning."""
    import sys
    import warnings

    sys.path.insert(0, str(Path(__file__).parent))
    from calib_decks import INS, OUTS, write_modal_test, write_plate
    from femcal.model import EigenRequest
    from femcal.solve.normal_modes import solve_normal_modes
    from femcal.testdata.formats import read_frf

    model, _ = write_plate(tmp_path)
    write_modal_test(tmp_path / "test.npz", model, OUTS, INS)
    fe, _ = solve_normal_modes(model, request=EigenRequest(nd=40))
    band = (8.0, 420.0)
    true = fe.frequencies_hz[(fe.frequencies_hz > band[0]) & (fe.frequencies_hz < band[1])]
    assert len(true) == 12
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a warning fails the test
        got = identify(read_frf(tmp_path / "test.npz"), band, settings=Settings(method=method))
    np.testing.assert_allclose(got.frequency_hz, true, rtol=5e-4)
    np.testing.assert_allclose(got.damping_ratio, 0.02, rtol=0.02)
    assert np.median(got.fit_error) < 0.01 and not got.warnings


def test_peaks_stand_out_of_the_noise_floor_and_the_floor_is_found():
    """A resonance one line wide and a broad one count as peaks; a noise floor's scatter (10 %
    from line to line, over the upper third) makes none, and is said to be noise-like."""
    from femcal.identify.indicators import find_cmif_peaks, noisy_regions

    rng = np.random.default_rng(3)
    f = np.arange(1.0, 1001.0, 0.1)
    w = 2 * np.pi * f
    H = np.zeros(len(f), complex)
    for fn, z in ((100.0, 2e-4), (400.0, 0.02)):  # 0.04 Hz and 16 Hz half-power bandwidths
        wn = 2 * np.pi * fn
        H += 1.0 / (wn**2 - w**2 + 2j * z * wn * w)
    floor = np.abs(H[(f > 650) & (f < 700)]).mean()
    top = f > 700
    H[top] = floor * (1 + 0.1 * rng.standard_normal(top.sum())) * np.exp(2j * np.pi * rng.random(top.sum()))
    S = np.abs(H)[None, :]
    peaks = find_cmif_peaks(f, S)
    np.testing.assert_allclose(peaks.frequency_hz, [100.0, 400.0], atol=0.5)
    (a, b), = noisy_regions(f, S)
    assert 690 < a < 720 and b > 990


def test_the_bundled_hammer_test_gives_its_seven_modes_with_only_the_band():
    """72 x 2, 2 % noise: the hidden frame's seven modes in 10-120 Hz, no splits given."""
    import tomllib
    import warnings

    from femcal.testdata.formats import read_frf

    frame = Path(__file__).parent.parent / "models" / "truck_frame"
    truth = tomllib.loads((frame / "hammer_test.truth.toml").read_text())["modes"]
    f_true = np.array(truth["frequency_hz"])
    z_true = np.array(truth["damping_ratio"])
    sel = (f_true > 10) & (f_true < 120)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning either
        model = identify(read_frf(frame / "hammer_test.uff"), (10.0, 120.0))
    np.testing.assert_allclose(model.frequency_hz, f_true[sel], rtol=2e-4)
    np.testing.assert_allclose(model.damping_ratio, z_true[sel], rtol=0.03)
    assert (model.mpc > 0.99).all() and np.median(model.frf_correlation) > 0.99


@pytest.mark.parametrize("method", ["plscf", "subspace"])
def test_close_modes_of_one_part_both_stay(method):
    """Two modes 0.4 % apart (0.2 Hz, ten lines, half a half-power bandwidth each side) that
    a part's diagram separates stay two modes through the joining of the parts."""
    fn, zeta = np.array([30.0, 50.0, 50.2, 70.0]), np.array([0.01, 0.005, 0.005, 0.01])
    f = np.arange(20.0, 80.0, 0.02)
    rng = np.random.default_rng(3)
    phi, L = rng.normal(size=(12, 4)), rng.normal(size=(2, 4))
    w, wn = 2 * np.pi * f, 2 * np.pi * fn
    q = -(w**2) / (wn[:, None] ** 2 - w**2 + 2j * (zeta * wn)[:, None] * w)
    data = FRFData.from_labels(f, np.einsum("pk,mk,kf->pmf", phi, L, q),
                               [f"{i + 1}:+Z" for i in range(12)], ["100:+Y", "101:+Y"],
                               "accelerance", "")  # fmt: skip
    model = identify(data, (25.0, 75.0), settings=Settings(method=method))
    np.testing.assert_allclose(model.frequency_hz, fn, rtol=1e-6)
    np.testing.assert_allclose(model.damping_ratio, zeta, rtol=1e-4)
    assert not model.suspect.any() and model.fit_error.max() < 1e-6


def test_a_model_written_before_the_layout_was_kept_has_its_shapes_at_its_outputs(tmp_path):
    """An identified model's NPZ without the layout key (femcal before the layouts): its
    shapes are at its outputs, even with more inputs than outputs."""
    from femcal.io.identified import NPZ_KEYS, read_model, summary

    lam = complex(-0.5, 60.0)
    arrays = dict(A=np.array([[lam.real, -lam.imag], [lam.imag, lam.real]]),
                  B=np.ones((2, 3)), C=np.ones((2, 2)), D=np.zeros((2, 3)),
                  residual_states=np.zeros(2, bool), poles=np.array([lam]),
                  frequency_hz=np.array([abs(lam) / 2 / np.pi]), damping_ratio=np.array([0.008]),
                  shapes=np.array([[1.0 + 0j], [0.5 + 0j]]), participation=np.ones((3, 1), complex),
                  output_labels=np.array(["1:+Z", "2:+Z"]),
                  input_labels=np.array(["7:+Z", "8:+Z", "9:+Z"]), quantity=np.array("accelerance"),
                  units=np.array("m/s^2/N"), band=np.array([5.0, 20.0]), fit_error=np.zeros(2),
                  suspect=np.zeros(2, bool), consistency=np.full(2, np.nan))  # fmt: skip
    assert set(arrays) == set(NPZ_KEYS)
    np.savez(tmp_path / "old.npz", **arrays)
    model = read_model(tmp_path / "old.npz")
    assert not model.layout.transposed
    assert [c.label for c in model.shape_channels] == ["1:+Z", "2:+Z"]
    assert list(summary(model)["poles"][0]["shape"]) == ["1:+Z", "2:+Z"]


def test_hostile_inputs_found_in_review_give_clear_answers(tmp_path, capsys):
    """A coherence with NaN names the FRF and frequency; --units keeps the coherence; data
    in absurd units give the same modes and no NumPy warning; the same reference twice is
    said; repeated --split is refused; a coherence of 0 throughout is not used, and said."""
    import warnings
    from dataclasses import replace

    from femcal.cli import main
    from femcal.errors import FemcalWarning
    from femcal.testdata.data import convert_units
    from femcal.testdata.formats.npz import write_npz

    data, _ = modal_set(noise=0.01, seed=5)
    coh = np.full(data.H.shape, 0.9)
    coh[3, 1, 7] = np.nan
    with pytest.raises(FRFError, match=r"the coherence of output 4:\+Z / input 101:\+Y at "
                       r"1\.7 Hz is nan \(1 such value\)"):
        replace(data, coherence=coh)
    coh[3, 1, 7] = 0.5
    back = convert_units(replace(data, coherence=coh), "m/s^2/N")
    assert back.coherence is not None and back.units == "m/s^2/N"
    ref = identify(data, BAND)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no NumPy warning, no FemcalWarning either
        huge = identify(replace(data, H=data.H * 1e90), BAND)
        tiny = identify(replace(data, H=data.H * 1e-90), BAND)
    for other in (huge, tiny):
        np.testing.assert_allclose(other.frequency_hz, ref.frequency_hz, rtol=1e-6)
    twice = FRFData(data.frequency_hz, np.stack([data.H[:, 0], data.H[:, 0]], axis=1),
                    data.outputs, data.inputs, data.quantity, data.units)  # fmt: skip
    with pytest.warns(FemcalWarning, match="references .* are linearly dependent"):
        identify(twice, BAND)
    with pytest.warns(FemcalWarning, match="the coherence is 0 at every line"):
        identify(replace(data, coherence=np.zeros(data.H.shape)), BAND)
    src = write_npz(tmp_path / "d.npz", data)
    assert main(["identify", str(src), "--band", "15", "100", "--split", "40", "40"]) == 2
    assert "--split 40 40: expected increasing frequencies, each once" in capsys.readouterr().err
    assert main(["identify", str(src), "--band", "15", "100", "--max-order", "150"]) == 2
    assert "expected at most 120 for plscf" in capsys.readouterr().err


def test_a_mode_the_band_cuts_is_fitted_and_a_mode_past_the_data_is_said():
    """A band ending 2 % below the 130 Hz mode: the band is widened to the CMIF's valley
    beyond it, the mode identified, the fit as good as with a band ending in a valley, and
    the model says so. Data ending 1.5 % below that mode: the rise to the end is said, with
    a valley to end in instead."""
    from femcal.identify.workflow import EDGE_REACH, edge_modes

    data, _ = modal_set(noise=0.01, seed=3)
    cut = identify(data, (15.0, 127.4))
    assert cut.band[1] > 130.0 and cut.band[1] < 130.0 * (1 + 2 * EDGE_REACH) + 1
    assert np.min(np.abs(cut.frequency_hz - 130.0)) < 0.2
    assert any("a mode at 130" in w and "widened" in w for w in cut.warnings)
    valley = identify(data, (15.0, 100.0))
    assert np.median(cut.fit_error) < 2 * np.median(valley.fit_error)
    assert edge_modes(data, (15.0, 100.0)) == ((15.0, 100.0), [])  # 100 Hz: a valley
    short = FRFData(data.frequency_hz[data.frequency_hz <= 128.05],
                    data.H[..., data.frequency_hz <= 128.05], data.outputs, data.inputs,
                    data.quantity, data.units)  # fmt: skip
    band, notes = edge_modes(short, (15.0, float(short.frequency_hz[-1])))
    assert band[1] == pytest.approx(short.frequency_hz[-1])
    assert len(notes) == 1 and "a mode lies just above the data" in notes[0]
    end = float(re.search(r"valley at ([0-9.]+) Hz", notes[0]).group(1))
    assert 100.0 < end < 128.0
