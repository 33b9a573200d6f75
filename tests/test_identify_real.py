"""Identification of real measured FRFs (tests/data/real, each with its source, licence and
published result): every published mode within the reference's own accuracy, with only the
band given, in the layout the lab measured, transposed, and through every file format femcal
writes (UFF 58 binary and text as a lab's software writes them, MATLAB, NPZ).

The fast tier identifies the beam and the single FRFs as measured, and the beam over two modes
transposed; the slow tier (about 3 minutes) the aircraft, and every set in every layout and
format, and checks that a real set and its transpose give the same poles to 1e-6.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import scipy.io

from femcal.correlate.shapes import mac
from femcal.errors import FemcalWarning
from femcal.identify import identify
from femcal.testdata.data import Channel, FRFData
from femcal.testdata.formats import read_frf, write_frf

from .browser import assert_verdict_first_at_1024, needs_browser

REAL = Path(__file__).parent / "data" / "real"


def published(folder: str) -> dict:
    return json.loads((REAL / folder / "published.json").read_text())


def beam() -> FRFData:
    return read_frf(REAL / "modelab_beam" / "beam.npz")


def aircraft() -> FRFData:
    return read_frf(REAL / "uliege_aircraft" / "aircraft.npz")


def single_frf(case: str) -> FRFData:
    """A vibrationtesting file as the acquisition software saved it: the FRF of channel 2 over
    channel 1 and its coherence (a few lines of case1 exceed 1 by the estimator's round-off:
    clipped). The quantity and units are not documented: taken as a receptance, units not
    given."""
    z = scipy.io.loadmat(REAL / "vibrationtesting" / case)
    f = z["Freq_domain"].ravel()
    H = z["Hf_chan_2"].ravel()
    coh = np.clip(z["Hf_coh_chan_2"].ravel(), 0.0, 1.0)
    return FRFData(f, H[None, None, :], (Channel.parse("2:3"),), (Channel.parse("1:3"),),
                   "receptance", "", coherence=coh[None, :])  # fmt: skip


def transposed(data: FRFData) -> FRFData:
    coh = data.coherence
    if coh is not None and coh.ndim == 3:
        coh = np.swapaxes(coh, 0, 1)
    elif coh is not None:
        coh = None  # a multiple coherence of the outputs does not transpose
    return FRFData(data.frequency_hz, np.swapaxes(data.H, 0, 1), data.inputs, data.outputs,
                   data.quantity, data.units, coherence=coh)  # fmt: skip


def gridded(data: FRFData) -> FRFData:
    """Channels a universal file can name: labels that are not GRID:DIR become grids 1001..
    in component 3."""
    def fix(chans):
        return tuple(c if c.grid is not None else Channel.parse(f"{1001 + k}:3")
                     for k, c in enumerate(chans))  # fmt: skip

    return replace(data, outputs=fix(data.outputs), inputs=fix(data.inputs))


def through(data: FRFData, fmt: str, folder: Path) -> FRFData:
    """The data written in ``fmt`` (npz, mat, uff binary or text) and read back."""
    if fmt == "uff-text":
        from femcal.testdata.formats.uff import write_uff

        return read_frf(write_uff(folder / "set.uff", gridded(data), binary=False))
    if fmt == "uff":
        from femcal.testdata.formats.uff import write_uff

        return read_frf(write_uff(folder / "set.uff", gridded(data), binary=True))
    return read_frf(write_frf(folder / f"set.{fmt}", data))


def identified(data: FRFData, band) -> tuple:
    """The model and the warnings it gave."""
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always", FemcalWarning)
        model = identify(data, tuple(band))
    return model, [str(w.message) for w in said]


def matched(found_hz: np.ndarray, modes_hz: list[float]) -> np.ndarray:
    """Each published mode's nearest identified mode (one to one, nearest pairs first):
    the frequency differences (Hz), NaN where none is left."""
    pairs = sorted((abs(f - m), i, j) for i, m in enumerate(modes_hz)
                   for j, f in enumerate(found_hz))  # fmt: skip
    diff = np.full(len(modes_hz), np.nan)
    used = set()
    for _, i, j in pairs:
        if np.isnan(diff[i]) and j not in used:
            diff[i] = found_hz[j] - modes_hz[i]
            used.add(j)
    return diff


def assert_published_modes(model, ref: dict, modes: list[float] | None = None) -> None:
    modes = ref["modes_hz"] if modes is None else modes
    diff = matched(model.frequency_hz, modes)
    far = [f"{m} Hz ({'none' if np.isnan(d) else f'{d:+.3f} Hz'})"
           for m, d in zip(modes, diff, strict=True) if not abs(d) <= ref["accuracy_hz"]]
    assert not far, f"published modes not found within {ref['accuracy_hz']} Hz: {far}"


def test_the_beam_as_measured_finds_its_four_modes_and_their_shapes_at_the_nine_points():
    """The roving-hammer layout (1 accelerometer x 9 hammer points) with only the band: the
    shapes come out at the nine points, as the published plots draw them."""
    ref = published("modelab_beam")
    model, said = identified(beam(), ref["band_hz"])
    assert_published_modes(model, ref)
    assert [c.label for c in model.shape_channels] == [f"{k}:+X" for k in range(1, 10)]
    assert model.layout.transposed and model.layout.kind == "roving hammer"
    for k, f in enumerate(ref["modes_hz"]):
        j = int(np.argmin(np.abs(model.frequency_hz - f)))
        read = np.array(ref["shapes_read_off_the_figure"][f"{f:.2f}"])[:, None]
        assert mac(model.shapes[:, [j]], read)[0, 0] > 0.9, (f, k)
        assert model.mpc[j] > 0.95 and 0 < model.damping_ratio[j] < 0.001
    # a lightly damped real set: nothing but its four modes, and no peak left unexplained
    assert len(model.frequency_hz) == 4
    assert not any("peak(s) of the CMIF have no identified mode" in s for s in said)


@pytest.mark.slow
def test_the_aircraft_as_measured_finds_its_published_poles():
    """3 accelerometers x 74 hammer points with their coherence: every one of the author's
    PolyMAX poles, the close pair at 125.2/125.69 Hz (four lines apart) included."""
    ref = published("uliege_aircraft")
    model, _ = identified(aircraft(), ref["band_hz"])
    assert_published_modes(model, ref)
    assert len(model.shape_channels) == 74 and model.layout.transposed


@pytest.mark.parametrize("case", ["case1.mat", "case2.mat"])
def test_single_noisy_frfs_with_their_coherence(case):
    ref = published("vibrationtesting")
    model, _ = identified(single_frf(case), ref["band_hz"])
    assert_published_modes(model, ref, ref["modes_hz"][case])


def test_a_set_and_its_transpose_agree_to_a_millionth():
    """N x 1 and 1 x N are one identification (the larger side is the roving one): the
    beam's 1 x 9 and 9 x 1 over two of its modes."""
    a, _ = identified(beam(), (250.0, 650.0))
    b, _ = identified(transposed(beam()), (250.0, 650.0))
    assert len(a.frequency_hz) == 2
    np.testing.assert_allclose(b.frequency_hz, a.frequency_hz, rtol=1e-6)
    np.testing.assert_allclose(b.damping_ratio, a.damping_ratio, rtol=1e-6)
    assert abs(mac(a.shapes, b.shapes).diagonal() - 1).max() < 1e-6
    assert [c.label for c in a.shape_channels] == [c.label for c in b.shape_channels]


@pytest.mark.slow
@pytest.mark.parametrize("fmt", ["npz", "mat", "uff", "uff-text"])
@pytest.mark.parametrize("layout", ["as measured", "transposed"])
@pytest.mark.parametrize("folder", ["modelab_beam", "uliege_aircraft"])
def test_every_layout_and_format_finds_the_published_modes(tmp_path, folder, layout, fmt):
    ref = published(folder)
    data = beam() if folder == "modelab_beam" else aircraft()
    if layout == "transposed":
        data = transposed(data)
    back = through(data, fmt, tmp_path)
    model, said = identified(back, ref["band_hz"])
    assert_published_modes(model, ref)
    if fmt.startswith("uff") and folder == "modelab_beam":
        # UFF 58 keeps the abscissa step in single precision: the axis ends a hair short of
        # 1000 Hz, and the band's edge is moved onto it, with a warning
        assert back.frequency_hz[-1] < 1000.0
        assert any("band edge 1000 Hz lies" in s for s in said)


@pytest.mark.slow
@pytest.mark.parametrize("folder", ["modelab_beam", "uliege_aircraft"])
def test_a_real_set_and_its_transpose_give_the_same_poles(folder):
    ref = published(folder)
    data = beam() if folder == "modelab_beam" else aircraft()
    a, _ = identified(data, ref["band_hz"])
    b, _ = identified(transposed(data), ref["band_hz"])
    np.testing.assert_allclose(b.frequency_hz, a.frequency_hz, rtol=1e-6)
    np.testing.assert_allclose(b.damping_ratio, a.damping_ratio, rtol=1e-6)
    assert [c.label for c in a.shape_channels] == [c.label for c in b.shape_channels]


def test_cli_both_methods_side_by_side_with_the_shapes_at_the_hammer_points(tmp_path, capsys):
    """`femcal identify --method both` on the beam's roving-hammer file over two modes:
    both tables, the comparison, the subspace model beside pLSCF's, and the universal file of
    shapes at the nine hammer points."""
    from femcal.cli import main
    from femcal.io.identified import read_model

    out = tmp_path / "out"
    rc = main(["identify", str(REAL / "modelab_beam" / "beam.npz"), "--band", "250", "650",
               "--method", "both", "--out", str(out)])  # fmt: skip
    assert rc == 0
    printed = capsys.readouterr()
    assert "plscf Hz" in printed.out and "subspace Hz" in printed.out
    assert "roving hammer: 1 response channel (4:-X) as reference" in printed.err
    assert "measured along a negative axis (4:-X)" in printed.err
    rows = json.loads((out / "comparison.json").read_text())
    both = [r for r in rows if None not in r["frequency_hz"]]
    assert len(both) == 2 and all(r["mac"] > 0.99 for r in both)
    for folder in (out, out / "subspace"):
        model = read_model(folder / "model.npz")
        assert [c.label for c in model.shape_channels] == [f"{k}:+X" for k in range(1, 10)]
        for name in ("indicators.png", "overlay.png", "stabilization_part1.png"):
            assert (folder / name).stat().st_size > 0
    text = (out / "identified_shapes.unv").read_text()
    assert sum(line.rstrip() == "    55" for line in text.splitlines()) == 2
    summary = json.loads((out / "identify.json").read_text())
    assert summary["layout"]["kind"] == "roving hammer"
    assert len(summary["poles"][0]["shape"]) == 9 and summary["poles"][0]["mpc"] > 0.95
    # the page opens on its verdict: the two modes of the real beam, the fit, no doubt
    page = (out / "identification.html").read_text()
    assert page.index("id='verdict'") < page.index("id='modes'") < page.index("id='provenance'")
    freqs = ", ".join(f"{p['frequency_hz']:.2f}" for p in summary["poles"])
    verdict = page[page.index("id='verdict'"):page.index("</section>")]
    assert "2 in 250-650 Hz (plscf)" in verdict and f"{freqs} Hz" in verdict
    assert "beam.npz" in page[page.index("id='provenance'"):]


def test_a_band_from_zero_hz_leaves_the_dc_line_out():
    """The single FRFs start at a 0 Hz line: a band from 0 starts at the first line above."""
    lines = []
    data = single_frf("case1.mat")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FemcalWarning)
        model = identify(data, (0.0, 312.0), progress=lines.append)
    assert model.band[0] == pytest.approx(data.frequency_hz[1])
    assert any("the first line above 0 Hz" in line for line in lines)
    ref = published("vibrationtesting")
    assert_published_modes(model, ref, ref["modes_hz"]["case1.mat"])


@needs_browser
def test_the_page_opens_on_its_verdict_and_fits_1024_pixels(tmp_path):
    from femcal.cli import main

    out = tmp_path / "out"
    assert main(["identify", str(REAL / "modelab_beam" / "beam.npz"), "--band", "250", "650",
                 "--out", str(out)]) == 0  # fmt: skip
    assert_verdict_first_at_1024(out / "identification.html", tmp_path / "page.png")


def test_the_verdict_doubts_complex_edge_damped_and_alike_modes():
    from femcal.io.identify_page import identification_verdict

    model = identify(read_frf(REAL / "modelab_beam" / "beam.npz"), (250.0, 650.0))
    assert identification_verdict(model).all_doubts == ()  # two clean modes
    f, z = model.frequency_hz.copy(), model.damping_ratio.copy()
    f[0], z[1] = 252.0, 0.2  # mode 1 at the band's bottom edge; mode 2 heavily damped
    shapes = np.column_stack([model.shapes[:, 0], model.shapes[:, 0] * 1j])  # alike
    bad = replace(model, frequency_hz=f, damping_ratio=z, shapes=shapes,
                  mpc=np.array([0.5, 0.99]), mpd=np.array([40.0, 2.0]),
                  suspect=np.eye(1, len(model.suspect), 3, dtype=bool)[0])  # fmt: skip
    v = identification_verdict(bad)
    assert [d.split(":")[0].split(" lies")[0] for d in v.doubts] == [
        "Mode 1 at 252.00 Hz", "Mode 1 at 252.00 Hz", "Mode 2 at 596.37 Hz",
        "Modes the sensors can hardly tell apart (AutoMAC over 0.5)"]
    assert "MPC 0.50, MPD 40 deg" in v.doubts[0] and "edge of the band" in v.doubts[1]
    assert "damping 20.0 %" in v.doubts[2] and "1 and 2 (1.00)" in v.doubts[3]
    assert not any("found twice" in d for d in v.doubts)  # 252 and 596 Hz: two modes
    assert len(v.channel_doubts) == 1 and v.channel_doubts[0].startswith("Channel 4:+X")
    ratio = bad.fit_error[3] / np.median(bad.fit_error)
    assert f"{ratio:.1f} times the median channel's" in v.channel_doubts[0]
    assert v.sentence.startswith("2 modes identified in 250-650 Hz")
    assert "1 suspect channel;" in v.sentence and "5 points to doubt" in v.sentence
    # alike and close: possibly one mode found twice
    f2 = f.copy()
    f2[1] = 1.02 * f2[0]
    twice = identification_verdict(replace(bad, frequency_hz=f2))
    assert any("possibly one mode found twice" in d for d in twice.doubts)
