"""Issue 39's cases: the drive iteration finds the drive that was played, not merely one that
matches the response.

The "physical rig" is the battery-box rig frame with the hammer test's hidden values, the
cross support the model lacks and 1.2 % damping; the model is the nominal deck with 2 %. A
band-limited random drive (1 mm RMS, 0.5-30 Hz) played on the physical rig makes the target
at the 7 control accelerometers. The iteration (on the physical rig, inverting the model's
FRF or the one measured on the rig) must find that drive: within 15 % of it in 1-30 Hz and
at most 1.25 times its RMS, the response within 5 % of the noise-free target in the band.
With 3 % noise on the target, no estimator recovers the drive line by line where the
accelerations are below the noise (low frequencies); there the drive must be held, not
amplified, and where it can be found it must be: its difference from the played one is
held to the best any linear estimator can do (the Wiener bound with the true drive's power
known), its level within 15 %.
"""

from __future__ import annotations

import json
import tomllib

import numpy as np
import pytest

from femcal.assembly import Options, assemble
from femcal.cli import main
from femcal.jobs.synthetic_test import hidden_values, with_cross_support
from femcal.model.build import load_model
from femcal.rig.iterate import IterationSettings, frf_on_lines, iterate_drive, measured_frf
from femcal.rig.plant import build_plant
from femcal.rig.simulate import simulate
from femcal.testdata.formats import read_time_data, write_time_data
from femcal.testdata.points import read_points
from femcal.testdata.timedata import TimeData

from .conftest import ROOT

FRAME = ROOT / "models" / "truck_frame"
CONTROL = ("S_V_front_left:+Z", "S_V_front_right:+Z", "S_V_rear_left:+Z",
           "S_V_rear_right:+Z", "S_L_front:+Y", "S_L_rear:+Y", "S_X_rear:-X")  # fmt: skip
DT = 1 / 512
SECONDS = 32.0
DRIVE_BAND = (0.5, 30.0)


@pytest.fixture(scope="module")
def rig():
    """(model plant, physical plant, control indices, played drive, noise-free target)."""
    deck = FRAME / "rig_frame_battery.bdf"
    actuators = read_points(FRAME / "rig_frame_battery.inputs.csv")
    sensors = read_points(FRAME / "rig_frame_battery.sensors.csv")
    model = build_plant(load_model(deck), actuators, sensors, modes_to=200.0, damping=0.02)
    with open(FRAME / "hammer_test.truth.toml", "rb") as fh:
        truth = tomllib.load(fh)
    given = {p["name"]: p["true"] for p in truth["parameter"]}
    frame, _ = hidden_values(load_model(deck), FRAME / "hammer_frame.params.toml", 0.0,
                             np.random.default_rng(0), given)  # fmt: skip
    mats = with_cross_support(frame, assemble(frame, Options()), truth["support_x_mm"],
                              truth["support_stiffness_nmm_per_rad"])  # fmt: skip
    physical = build_plant(frame, actuators, sensors, modes_to=200.0, matrices=mats,
                           damping=0.012)  # fmt: skip
    control = [model.outputs.index(c) for c in CONTROL]
    n = round(SECONDS / DT)
    f = np.fft.rfftfreq(n, DT)
    rng = np.random.default_rng(39)
    lines = (f >= DRIVE_BAND[0]) & (f <= DRIVE_BAND[1])
    S = np.zeros((7, len(f)), complex)
    S[:, lines] = np.exp(2j * np.pi * rng.uniform(size=(7, int(lines.sum()))))
    played = np.fft.irfft(S, n, axis=1)
    played /= np.sqrt(np.mean(played**2, axis=1, keepdims=True))
    target = simulate(physical, played, DT, periodic=True)[control]
    return model, physical, control, played, target


def _spectra(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    return np.fft.rfftfreq(x.shape[1], DT), np.fft.rfft(x, axis=1)


def drive_error(found: np.ndarray, played: np.ndarray, band=(1.0, 30.0)):
    """(difference in the band over the played drive's RMS there, the found drive's RMS
    there over the played one's), per actuator."""
    f, D = _spectra(found)
    _, P = _spectra(played)
    lines = (f >= band[0]) & (f <= band[1])
    size = np.linalg.norm(P[:, lines], axis=1)
    return (np.linalg.norm(D[:, lines] - P[:, lines], axis=1) / size,
            np.linalg.norm(D[:, lines], axis=1) / size)  # fmt: skip


def response_error(response: np.ndarray, clean: np.ndarray) -> np.ndarray:
    f, R = _spectra(response)
    _, T = _spectra(clean)
    lines = (f >= DRIVE_BAND[0]) & (f <= DRIVE_BAND[1])
    return np.linalg.norm(R[:, lines] - T[:, lines], axis=1) / np.linalg.norm(T[:, lines],
                                                                              axis=1)


@pytest.mark.parametrize("frf", ["model", "measured"])
def test_the_drive_played_is_found_on_a_frame_unlike_the_model(rig, frf):
    model, physical, control, played, target = rig
    n = target.shape[1]
    settings = IterationSettings(iterations=8)
    H = (frf_on_lines(model, control, n, DT, settings.band) if frf == "model"
         else measured_frf(physical, control, n, DT, settings.band))  # fmt: skip
    it = iterate_drive(physical, H, target.astype(np.float32).astype(float), control, DT,
                       settings)  # fmt: skip
    diff, level = drive_error(it.drive, played)
    assert diff.max() < 0.15, diff
    assert np.all(np.abs(level - 1) < 0.15), level
    rms = np.sqrt(np.mean(it.drive**2, axis=1))
    assert rms.max() < 1.25, rms
    assert response_error(it.response[control], target).max() < 0.05
    assert it.taper_s == 0.0  # one period of a looped drive: its ends join
    assert all(s.startswith(("converged", "still falling")) for s in it.status), it.status


def test_noise_on_the_target_is_not_amplified_into_the_drive(rig):
    _model, physical, control, played, target = rig
    n = target.shape[1]
    rng = np.random.default_rng(3)
    size = np.sqrt(np.mean(target**2, axis=1, keepdims=True))
    noise = 0.03 * size * rng.standard_normal(target.shape)
    settings = IterationSettings(iterations=8)
    H = measured_frf(physical, control, n, DT, settings.band)
    it = iterate_drive(physical, H, target + noise, control, DT, settings)
    assert np.allclose(it.noise.fraction * np.sqrt(np.mean((target + noise) ** 2, axis=1)),
                       0.03 * size[:, 0], rtol=0.15)  # the floor measured above the band
    rms = np.sqrt(np.mean(it.drive**2, axis=1))
    assert rms.max() < 1.25, rms
    diff, level = drive_error(it.drive, played)
    assert np.all(np.abs(level - 1) < 0.15), level
    assert response_error(it.response[control], target).max() < 0.05
    # the Wiener bound: the best a linear estimator does line by line knowing the drive's
    # power, with the plant's own FRF
    f, P = _spectra(played)
    _, N = _spectra(noise)
    lines = (f >= 1.0) & (f <= 30.0)
    Hp = np.moveaxis(physical.frf(f[lines])[control], 2, 0)
    E = np.einsum("fij,jf->if", np.linalg.inv(Hp), N[:, lines])  # the noise in the drive
    p2, e2 = np.abs(P[:, lines]) ** 2, np.abs(E) ** 2
    bound = np.sqrt(np.sum(p2 * e2 / (p2 + e2), axis=1) / np.sum(p2, axis=1))
    assert np.all(diff < 1.5 * bound), (diff, bound)
    # the low band, where the accelerations are below the noise, is said to be held
    assert it.unseen and it.unseen[0].low_hz < 1.0 and it.unseen[0].directions == 7


def test_lvdts_in_the_control_set_release_the_drive_the_accelerometers_cannot_see(rig):
    """Mixed control: the actuators' displacements beside the accelerometers, each with its
    own noise, see the low band the accelerations cannot: the drive is found there too."""
    model, physical, control, played, _target = rig
    lvdt = [physical.outputs.index(f"{a}:displacement") for a in physical.inputs]
    both = control + lvdt
    clean = simulate(physical, played, DT, periodic=True)[both]
    rng = np.random.default_rng(4)
    noisy = clean + 0.03 * np.sqrt(np.mean(clean**2, axis=1, keepdims=True)) * (
        rng.standard_normal(clean.shape))
    n = clean.shape[1]
    settings = IterationSettings(iterations=6)
    it = iterate_drive(physical, frf_on_lines(model, both, n, DT, settings.band), noisy, both,
                       DT, settings, weights=[1.0] * 7 + [0.5] * 7)  # fmt: skip
    diff, _ = drive_error(it.drive, played, band=(0.5, 30.0))
    assert diff.max() < 0.05, diff
    assert not [u for u in it.unseen if u.low_hz < 2.0]


def test_the_shipped_rig_test_drive_stays_the_size_of_the_one_played(tmp_path, capsys):
    """A 32 s slice of the shipped rig test's accelerations (2 % noise, a frame unlike the
    model, its ends not joined) iterated on the model: the drive stays within 1.25 times
    the played one's RMS, inside its stroke, and the low band it cannot see is said."""
    rsp = read_time_data(FRAME / "rig_test.rsp")
    drv = read_time_data(FRAME / "rig_test.drv")
    n = round(SECONDS / rsp.dt)
    keep = [rsp.channel(c) for c in CONTROL]
    write_time_data(tmp_path / "target.rsp",
                    TimeData(rsp.dt, rsp.values[keep][:, :n], CONTROL,
                             tuple(rsp.units[k] for k in keep)))  # fmt: skip
    write_time_data(tmp_path / "played.rsp",
                    TimeData(drv.dt, drv.values[:, :n], drv.names, drv.units))
    out = tmp_path / "it"
    assert main(["rig", "iterate", str(FRAME / "rig_frame.bdf"), "--actuators",
                 str(FRAME / "rig_frame.inputs.csv"), "--sensors",
                 str(FRAME / "rig_frame.sensors.csv"), "--target", str(tmp_path / "target.rsp"),
                 "--control", *CONTROL, "--iterations", "4", "--reference-drive",
                 str(tmp_path / "played.rsp"), "--out", str(out)]) == 0  # fmt: skip
    text = capsys.readouterr().out
    assert "the target's ends do not join" in text
    assert "not seen above the noise at 0.5-" in text
    report = json.loads((out / "iteration.json").read_text())
    found = read_time_data(out / "drive.rsp")
    played = np.sqrt(np.mean(drv.values[:, :n] ** 2, axis=1))
    rms = np.sqrt(np.mean(found.values**2, axis=1))
    assert np.all(rms < 1.25 * played), rms / played
    stroke = np.array([d["limit_stroke"] for d in report["drives"]])
    assert np.all(np.abs(found.values).max(axis=1) < stroke)
    assert report["limits"]["drive_written"] and not report["limits"]["exceeded"]
    assert report["noise_floor"]["measured"] is True
    assert all(0.015 < c["noise_floor"] < 0.025 for c in report["control"])
    assert report["final_rms_error"]["worst"] < 0.02  # in the band
    assert all(abs(c["relative_damage"] - 1) < 0.1 for c in report["control"])
    for name in ("drives_psd.png", "drives_time.png", "error_psd.png", "report.html"):
        assert (out / name).stat().st_size > 1000


def test_the_seven_post_warp_is_found_and_held_when_asked(rig):
    """The rig's one redundant combination is the warp of the four vertical posts; with
    --warp minimal the drive found has none of it, and the response pays for that, while
    the free iteration drives the warp that was played."""
    from femcal.rig.kinematics import redundant_drives, rigid_body_drives

    model, physical, control, played, target = rig
    J = rigid_body_drives(model)
    assert J.shape == (7, 6) and np.linalg.matrix_rank(J) == 6
    warp = redundant_drives(model)
    assert warp.shape == (7, 1)
    assert np.allclose(warp[:, 0], [0.5, -0.5, -0.5, 0.5, 0, 0, 0], atol=1e-9)
    n = target.shape[1]
    H = frf_on_lines(model, control, n, DT, (0.5, 40.0))
    runs = {w: iterate_drive(physical, H, target, control, DT,
                             IterationSettings(iterations=6, warp=w)) for w in ("free", "minimal")}
    played_warp = np.linalg.norm(warp[:, 0] @ played)
    free, minimal = (np.linalg.norm(warp[:, 0] @ runs[w].drive) for w in ("free", "minimal"))
    assert abs(free / played_warp - 1) < 0.05
    assert minimal < 0.01 * played_warp
    held = response_error(runs["minimal"].response[control], target).max()
    assert held > 0.05 and held > 5 * response_error(runs["free"].response[control],
                                                     target).max()
    assert runs["free"].redundant.shape == (7, 1) and runs["free"].redundant_unseen == ((),)
    assert any("--warp minimal" in st for st in runs["minimal"].status), runs["minimal"].status
