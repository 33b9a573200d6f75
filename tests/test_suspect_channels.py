"""Suspect channels: a test whose sensors carry the mistakes a lab makes (a wrong calibration
factor, a sensor mounted reversed, axes swapped, a sensor on the next grid) has each of them
flagged with that reason, and the sound channels are not flagged. The test FRFs are the plate
model's own at the sensors' true places with 2 % noise; the file's labels carry the
mistakes."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.calibrate.channels import STANDOUT_FACTOR, suspect_channels
from femcal.model import EigenRequest
from femcal.model.build import load_model
from femcal.response.frf import channel_matrix, modal_frf
from femcal.solve.normal_modes import solve_normal_modes
from femcal.testdata.data import Channel

from .calib_decks import plate_deck

ZETA = 0.02
INS = [Channel.parse("28:+Z"), Channel.parse("11:+Z")]
SOUND = ["3:+Z", "5:+Z", "7:+Z", "10:+Z", "14:+Z", "21:+Z", "26:+Z", "28:+Z"]
#: label in the file -> where the sensor really is, and the mistake's reason
MISTAKES = {"24:+Z": ("24:+Z", "calibration factor"), "19:+Z": ("19:-Z", "sign"),
            "17:+X": ("17:+Z", "direction"), "12:+Z": ("13:+Z", "location")}  # fmt: skip


@pytest.fixture(scope="module")
def plate(tmp_path_factory):
    path = tmp_path_factory.mktemp("plate") / "plate.bdf"
    path.write_text(plate_deck())
    model = load_model(path)
    modes, _ = solve_normal_modes(model, request=EigenRequest(nd=30))
    return model, modes


def _frf(model, modes, labels: list[str], f: np.ndarray) -> np.ndarray:
    C = channel_matrix(model, [Channel.parse(x) for x in labels])
    return modal_frf(modes.shapes, modes.radians, C, channel_matrix(model, INS).T, f, ZETA,
                     "accelerance")  # fmt: skip


def test_each_mistake_is_flagged_with_its_reason(plate):
    model, modes = plate
    f = np.geomspace(10.0, 400.0, 400)
    labels = SOUND + list(MISTAKES)
    true_places = SOUND + [where for where, _ in MISTAKES.values()]
    H_model = _frf(model, modes, labels, f)
    H_test = _frf(model, modes, true_places, f)
    H_test[labels.index("24:+Z")] *= 10.0  # volts per g entered as per m/s^2, say
    rng = np.random.default_rng(3)
    H_test = H_test * (1 + 0.02 * (rng.standard_normal(H_test.shape)
                                   + 1j * rng.standard_normal(H_test.shape)))  # fmt: skip
    outs = [Channel.parse(x) for x in labels]
    found = suspect_channels(outs, INS, f, H_test, H_model, model=model, modes=modes,
                             zeta=ZETA, quantity="accelerance", names={"24:+Z": "S24"})
    flagged = {s.label: s for s in found}
    assert set(flagged) == set(MISTAKES), [s.describe() for s in found]
    for label, (_, reason) in MISTAKES.items():
        s = flagged[label]
        assert s.reasons, s.describe()
        assert s.reasons[0].startswith(reason), s.describe()
        assert s.misfit_after > STANDOUT_FACTOR * s.median_after
    assert flagged["24:+Z"].level == pytest.approx(10.0, rel=0.05)
    assert "10 times the model" in flagged["24:+Z"].reasons[0]
    assert "grid 13" in flagged["12:+Z"].reasons[0]
    assert "+Z at grid 17" in flagged["17:+X"].reasons[0]
    assert flagged["24:+Z"].shown == "S24 (24:+Z)"
    assert "S24 (24:+Z): misfit" in flagged["24:+Z"].describe()


def test_a_channel_made_worse_by_calibration_is_flagged_before_and_after(plate):
    model, modes = plate
    f = np.geomspace(10.0, 400.0, 200)
    labels = [*SOUND, "24:+Z"]
    H = _frf(model, modes, labels, f)
    H_test = H.copy()
    H_test[-1] *= 5.0
    found = suspect_channels([Channel.parse(x) for x in labels], INS, f, H_test, H * 1.01,
                             H_before=H * 1.3, phase=False)  # fmt: skip
    assert [s.label for s in found] == ["24:+Z"]
    s = found[0]
    assert s.misfit_before < s.misfit_after  # 5/1.3 is nearer than 5/1.01
    assert s.worse_after and "worse after calibration" in s.describe()
    assert s.reasons and s.reasons[0].startswith("calibration factor")


def test_nothing_stands_out_in_a_sound_test(plate):
    model, modes = plate
    f = np.geomspace(10.0, 400.0, 200)
    H = _frf(model, modes, SOUND, f)
    rng = np.random.default_rng(5)
    noisy = H * (1 + 0.02 * rng.standard_normal(H.shape))
    assert suspect_channels([Channel.parse(x) for x in SOUND], INS, f, noisy, H, model=model,
                            modes=modes, zeta=ZETA, quantity="accelerance") == ()
