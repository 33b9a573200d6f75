"""The LMS Test.Lab MATLAB export layout: files written here field by field to that layout
(structs with x_values, y_values and function_record) are read into one MIMO set."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.io

from femcal.errors import FemcalWarning
from femcal.testdata.data import FRFError, convert_units, quantity_of_units
from femcal.testdata.formats import read_frf
from femcal.testdata.formats.lms import channel_label, read_lms_mat, split_function_name
from femcal.testdata.formats.matlab import read_mat

G = 9.80665


def lms_block(f0, df, values_si, names, *, label="g/N", factor=1 / G, uneven=None):
    """One Test.Lab function block as scipy.io writes a MATLAB struct (nested dicts)."""
    x = {"start_value": f0, "increment": df, "number_of_values": float(values_si.shape[0]),
         "quantity": {"label": "Hz"}}
    if uneven is not None:
        x["values"] = uneven
    return {
        "x_values": x,
        "y_values": {"values": values_si,
                     "quantity": {"label": label,
                                  "unit_transformation": {"factor": factor, "offset": 0.0}}},
        "function_record": {"name": np.array(names, dtype=object) if len(names) > 1
                            else names[0], "type": "FRF"},
    }


def make_set(rng, n=50):
    # two references (hammer Y at 1, hammer Z at 2), three responses, in m/s^2/N
    h = rng.normal(size=(n, 3, 2)) + 1j * rng.normal(size=(n, 3, 2))
    return h


def test_reads_grouped_blocks_per_reference_into_one_mimo_set(tmp_path):
    rng = np.random.default_rng(0)
    h = make_set(rng)
    resp = ["Point12:+Z", "frame:13:+X", "Point14:-Y"]
    path = tmp_path / "lms.mat"
    scipy.io.savemat(path, {
        "FRF": lms_block(2.0, 0.5, h[:, :, 0], [f"{r}/Point1:+Y" for r in resp]),
        "FRF_1": lms_block(2.0, 0.5, h[:, :, 1], [f"FRF {r}/Point2:+Z (g/N)" for r in resp]),
        "Notes": "not a function block",
    })
    for d in (read_lms_mat(path), read_mat(path), read_frf(path)):
        assert [c.label for c in d.outputs] == ["12:+Z", "13:+X", "14:-Y"]
        assert [(c.grid, c.direction) for c in d.inputs] == [(1, "+Y"), (2, "+Z")]
        assert d.quantity == "accelerance" and d.units == "g/N"
        np.testing.assert_allclose(d.frequency_hz, 2.0 + 0.5 * np.arange(50))
        np.testing.assert_allclose(d.H, np.transpose(h, (1, 2, 0)) / G, rtol=1e-14)
    mm = convert_units(read_frf(path), "mm/s^2/N")
    np.testing.assert_allclose(mm.H, np.transpose(h, (1, 2, 0)) * 1000, rtol=1e-14)


def test_single_channel_blocks_and_uneven_abscissa(tmp_path):
    f = np.array([1.0, 1.5, 3.0, 7.0])
    path = tmp_path / "one.mat"
    v = np.array([1 + 1j, 2, 3j, 4])
    scipy.io.savemat(path, {"FRF": lms_block(0.0, 0.0, v, ["Point7:+Z/Point7:+Z"],
                                             label="(m/s2)/N", factor=1.0, uneven=f)})  # fmt: skip
    d = read_lms_mat(path)
    assert d.H.shape == (1, 1, 4)
    np.testing.assert_array_equal(d.frequency_hz, f)
    np.testing.assert_array_equal(d.H[0, 0], v)
    assert d.quantity == "accelerance"


def test_names_and_units():
    assert channel_label("Point12:+Y") == "12:+Y"
    assert channel_label("frame:7:Z") == "7:+Z"
    assert channel_label("hammer:+Y") == "hammer:+Y"
    assert split_function_name("FRF Point3:+Z/Point1:-Y (g/N)", "x") == ("3:+Z", "1:-Y")
    with pytest.raises(ValueError, match="response/reference"):
        split_function_name("Point3:+Z", "file.mat: FRF")
    assert quantity_of_units("g/N") == "accelerance"
    assert quantity_of_units("(m/s)/N") == "mobility"
    assert quantity_of_units("mm/N") == "receptance"
    assert quantity_of_units("Pa/N") is None


def test_errors_name_the_file_block_and_pair(tmp_path):
    rng = np.random.default_rng(1)
    h = make_set(rng, 10)
    path = tmp_path / "gap.mat"
    scipy.io.savemat(path, {
        "FRF": lms_block(1.0, 1.0, h[:, :, 0], ["1:+X/9:+Y", "2:+X/9:+Y", "3:+X/9:+Y"]),
        "FRF_1": lms_block(1.0, 1.0, h[:, :2, 1], ["1:+X/8:+Z", "2:+X/8:+Z"]),
    })
    with pytest.raises(ValueError, match=r"gap.mat: 1 output/input pairs have no FRF: 3:\+X/8:\+Z"):
        read_lms_mat(path)
    scipy.io.savemat(path, {
        "FRF": lms_block(1.0, 1.0, h[:, :1, 0], ["1:+X/9:+Y"]),
        "FRF_1": lms_block(1.0, 2.0, h[:, :1, 1], ["1:+X/8:+Y"]),
    })
    with pytest.raises(ValueError, match=r"gap\.mat: FRF_1: on another frequency axis"):
        read_lms_mat(path)
    scipy.io.savemat(path, {"FRF": lms_block(1.0, 1.0, h[:, :2, 0], ["1:+X/9:+Y"])})
    with pytest.raises(ValueError, match="1 channel names for 2 columns"):
        read_lms_mat(path)
    scipy.io.savemat(path, {"FRF": lms_block(1.0, 1.0, h[:, :1, 0], ["1:+X/9:+Y"],
                                             label="Pa/N", factor=1.0)})  # fmt: skip
    with pytest.raises(ValueError, match="give the quantity"):
        read_lms_mat(path)
    assert read_lms_mat(path, quantity="accelerance").units == "Pa/N"
    scipy.io.savemat(path, {"something": np.eye(2)})
    with pytest.raises(FRFError, match=r"no Test\.Lab struct"):
        read_mat(path)
    with pytest.raises(ValueError, match="unknown FRF file type"):
        read_frf(tmp_path / "a.xyz")


def test_unit_conversion_refuses_other_quantities():
    from femcal.testdata.data import FRFData

    d = FRFData.from_labels([1.0, 2.0], np.ones((1, 1, 2)), ["1:+X"], ["2:+Y"],
                            "accelerance", "g/N")  # fmt: skip
    np.testing.assert_allclose(convert_units(d, "m/s^2/N").H, G)
    with pytest.raises(ValueError, match="cannot convert accelerance"):
        convert_units(d, "mm/N")
    with pytest.raises(ValueError, match="'furlong/N' is not one of"):
        convert_units(d, "furlong/N")


def test_files_that_are_not_what_their_suffix_says_are_named(tmp_path):
    for name in ("g.npz", "g.mat"):
        (tmp_path / name).write_text("not an FRF file")
        with pytest.raises(ValueError, match=rf"{name}: not an? "):
            read_frf(tmp_path / name)
    np.save(tmp_path / "one.npy", np.zeros(3))
    (tmp_path / "one.npy").rename(tmp_path / "one.npz")
    with pytest.raises(ValueError, match=r"one\.npz: not an NPZ archive"):
        read_frf(tmp_path / "one.npz")


# ----------------------------------------------------------------------------- damaged files


def patched(tmp_path, name, find: bytes, offset: int, value: int):
    """A one-block Test.Lab file (uncompressed) with the byte ``offset`` from where ``find``
    starts set to ``value``."""
    h = np.arange(1, 5) * (1 + 1j)
    path = tmp_path / name
    scipy.io.savemat(path, {"FRF": lms_block(1.0, 1.0, h, ["Point1:+X/Point9:+Y"])})
    raw = bytearray(path.read_bytes())
    raw[raw.index(find) + offset] = value
    path.write_bytes(raw)
    return path


def test_elements_that_crash_scipy_are_refused_before_it_reads_them(tmp_path):
    # SciPy's loadmat looks up an element's type code in a table without checking it: code
    # 80 (the fuzzer's case 2:1025) killed the process with a segmentation fault
    p = patched(tmp_path, "code.mat", b"g/N", -4, 80)
    with pytest.raises(FRFError, match=r"code\.mat: byte \d+: the characters of type code 80; "
                       r"expected one of \[1, 2"):  # fmt: skip
        read_frf(p)
    # a character array whose dimensions element holds no number (case 3:1211): SciPy's
    # chars_to_strings reads the missing last dimension and crashes
    p = patched(tmp_path, "dims.mat", b"Hz\x00", -26, 1)
    with pytest.raises(FRFError, match=r"dims\.mat: byte \d+: a character array without "
                       "dimensions; the MATLAB file is damaged"):  # fmt: skip
        read_frf(p)
    # the file as written passes the check
    assert read_frf(patched(tmp_path, "fine.mat", b"g/N", 0, ord("g"))).H.shape == (1, 1, 4)


def test_lms_fields_that_are_wrong_are_named(tmp_path):
    h = np.arange(1, 5) * (1 + 1j)
    path = tmp_path / "f.mat"

    def save(**change):
        block = lms_block(1.0, 1.0, h, ["Point1:+X/Point9:+Y"])
        for dotted, value in change.items():
            *parents, leaf = dotted.split("__")
            node = block
            for k in parents:
                node = node[k]
            if value is None:
                del node[leaf]
            else:
                node[leaf] = value
        scipy.io.savemat(path, {"FRF": block})
        return path

    with pytest.raises(FRFError, match=r"f\.mat: FRF: y_values\.values holds real \(float64\) "
                       "values; expected complex FRFs"):  # fmt: skip
        read_frf(save(y_values__values=h.real))
    with pytest.raises(FRFError, match=r"FRF: x_values\.number_of_values is 1e\+15; expected "
                       r"the number of values of y_values\.values"):  # fmt: skip
        read_frf(save(x_values__number_of_values=1e15))  # refused before it is allocated
    with pytest.raises(FRFError, match=r"FRF: x_values\.increment is nan; expected one finite"):
        read_frf(save(x_values__increment=np.nan))
    with pytest.raises(FRFError, match=r"f\.mat: FRF: x_values: frequency 2 of 4 \(1\.0 Hz\) "
                       "repeats frequency 1"):  # fmt: skip
        read_frf(save(x_values__increment=0.0))
    with pytest.raises(FRFError, match=r"unit_transformation\.factor is 'text'; expected one"):
        read_frf(save(y_values__quantity__unit_transformation__factor="text"))
    # without a transformation factor the values are SI: the unit says so, whatever the label
    d = read_frf(save(y_values__quantity__unit_transformation=None))
    assert d.units == "m/s^2/N" and d.quantity == "accelerance"
    np.testing.assert_allclose(d.H[0, 0], h)
    # a struct that is no block (a damaged one?) is named in a warning, not dropped silently
    block = lms_block(1.0, 1.0, h, ["Point1:+X/Point9:+Y"])
    scipy.io.savemat(path, {"FRF": block, "FRF_1": {"y_values": block["y_values"]}})
    with pytest.warns(FemcalWarning, match=r"f\.mat: struct FRF_1 is not a Test\.Lab function "
                      "block"):  # fmt: skip
        read_frf(path)
