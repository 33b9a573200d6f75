"""Model building: coordinates through chained systems, DOF map, references."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.deck import read_deck
from femcal.errors import ModelError
from femcal.model.build import build_model

HEAD = "SOL 103\nCEND\nBEGIN BULK\n"


def model(write, text):
    return build_model(read_deck(write(HEAD + text)))


def xyz_of(m, gid):
    return m.xyz[m.node_index(gid)[0]]


def test_rectangular_system_rotated_and_shifted(write):
    # CORD2R 1: origin (1,2,3), z along basic x, xz-plane containing basic y -> x along y.
    m = model(
        write, "CORD2R,1,0,1.,2.,3.,2.,2.,3.\n,1.,3.,3.\nGRID,1,1,1.,0.,0.\nGRID,2,1,0.,1.,0.\n"
    )
    assert np.allclose(xyz_of(m, 1), [1.0, 3.0, 3.0])  # local x = basic y
    assert np.allclose(xyz_of(m, 2), [1.0, 2.0, 4.0])  # local y = z x (C - A) = basic z


def test_cylindrical_and_spherical_points(write):
    m = model(
        write,
        "CORD2C,2,0,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\nCORD2S,3,0,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\n"
        "GRID,1,2,2.,90.,5.\nGRID,2,3,2.,90.,90.\nGRID,3,3,2.,0.,0.\n",
    )
    assert np.allclose(xyz_of(m, 1), [0.0, 2.0, 5.0])
    assert np.allclose(xyz_of(m, 2), [0.0, 2.0, 0.0])
    assert np.allclose(xyz_of(m, 3), [0.0, 0.0, 2.0])


def test_chained_systems_and_cord1_from_grids_in_other_systems(write):
    text = (
        "CORD2R,10,0,0.,0.,10.,0.,0.,11.\n,1.,0.,10.\n"  # shifted up 10
        "CORD2C,11,10,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\n"  # cylindrical inside 10
        "GRID,1,11,1.,90.,0.\nGRID,2,11,1.,90.,1.\nGRID,3,11,1.,180.,0.\n"
        "CORD1R,12,1,2,3\nGRID,4,12,0.,0.,2.\nGRID,5,12,1.,0.,0.\n"
    )
    m = model(write, text)
    assert np.allclose(xyz_of(m, 1), [0.0, 1.0, 10.0])
    assert np.allclose(xyz_of(m, 4), [0.0, 1.0, 12.0])  # z of 12 is basic z from grid 1
    # x of 12: the part of (grid 3 - grid 1) = (-1, -1, 0) normal to z, normalised
    assert np.allclose(xyz_of(m, 5), [-(0.5**0.5), 1.0 - 0.5**0.5, 10.0])


def test_cd_frames_cylindrical(write):
    m = model(write, "CORD2C,2,0,0.,0.,0.,0.,0.,1.\n,1.,0.,0.\nGRID,1,0,0.,3.,0.,2\n")
    f = m.cd_frames[m.node_index(1)[0]]
    assert (
        np.allclose(f[:, 0], [0, 1, 0])
        and np.allclose(f[:, 1], [-1, 0, 0])
        and np.allclose(f[:, 2], [0, 0, 1])
    )


def test_grdset_defaults_and_dof_map(write):
    m = model(write, "GRDSET,,,,,,,3456\nGRID,5\nGRID,2,,,,,,12\nSPOINT,3\n")
    assert m.node_ids.tolist() == [2, 3, 5]
    assert m.ps.tolist() == [12, 0, 3456]
    assert m.dof_start.tolist() == [0, 6, 7] and m.n_dof == 13
    assert m.dof_index([5, 3], [2, 0]).tolist() == [8, 6]


def test_missing_grid_names_element_and_location(write):
    with pytest.raises(ModelError) as e:
        model(write, "GRID,1\nGRID,2\nCROD,7,1,1,99\nPROD,1,1,1.\nMAT1,1,1.,,.3\n")
    assert "deck.bdf:6" in str(e.value) and "CROD 7" in str(e.value) and "99" in str(e.value)
    assert 7 in e.value.ids


def test_missing_property_and_material(write):
    with pytest.raises(ModelError) as e:
        model(write, "GRID,1\nGRID,2\nCROD,7,5,1,2\nCBAR,8,6,1,2,0.,1.,0.\nPBAR,6,9,1.\n")
    text = str(e.value)
    assert "CROD 7 refers to property 5" in text and "PROD" in text
    assert "PBAR 6 field MID refers to material 9" in text


def test_duplicate_ids(write):
    with pytest.raises(ModelError, match="GRID id 1 defined twice"):
        model(write, "GRID,1\nGRID,1\n")
    with pytest.raises(ModelError, match="element id 3 defined twice"):
        model(write, "GRID,1\nCONM2,3,1,,1.\nCONM2,3,1,,1.\n")


def test_undefined_and_cyclic_coordinate_systems(write):
    with pytest.raises(ModelError, match="GRID CP 4 is not a defined"):
        model(write, "GRID,1,4\n")
    with pytest.raises(ModelError, match="cycle"):
        model(write, "CORD2R,1,2,0.,0.,0.,0.,0.,1.\n,1.\nCORD2R,2,1,0.,0.,0.,0.,0.,1.\n,1.\n")


def test_degenerate_system(write):
    with pytest.raises(ModelError, match="do not define axes"):
        model(write, "CORD2R,1,0,0.,0.,0.,0.,0.,0.\n,1.\n")


def test_constraint_references_checked(write):
    with pytest.raises(ModelError, match="RBE2 1 refers to GRID/SPOINT \\[9\\]"):
        model(write, "GRID,1\nRBE2,1,1,123456,9\n")
    with pytest.raises(ModelError, match="SPC1 set 1"):
        model(write, "GRID,1\nSPC1,1,123,1,2\n")


def test_scalar_components_checked(write):
    with pytest.raises(ModelError, match="component must be one digit"):
        model(write, "GRID,1\nCELAS2,1,10.,1,0\n")
    m = model(write, "GRID,1\nSPOINT,5\nCELAS2,1,10.,1,3,5\n")
    b = m.elements["CELAS2"]
    assert b.components.tolist() == [[3, 0]] and b.nodes.tolist() == [[0, 1]]


def test_case_control_selections_that_name_no_set_stop_the_solution_not_the_reading(write):
    """A model whose case control SPC, MPC or METHOD is not a set id can be read and
    summarised (femcal info); solving it says what is wrong."""
    from femcal.cli import main
    from femcal.solve.normal_modes import solve_normal_modes

    path = write("SOL 103\nCEND\nMETHOD = 1\nSPC = ONE\nBEGIN BULK\nEIGRL,1,,,3\n"
                 "GRID,1,,0.,0.,0.\nGRID,2,,1.,0.,0.\nCROD,1,1,1,2\nPROD,1,1,1.\n"
                 "MAT1,1,2.1e5,,0.3,7.85e-9\nENDDATA\n")  # fmt: skip
    m = build_model(read_deck(path))
    assert m.constraints.problems == (f"{path}:4: case control SPC = ONE: expected a set id",)
    assert main(["info", str(path)]) == 0
    with pytest.raises(ModelError, match="case control SPC = ONE: expected a set id"):
        solve_normal_modes(m)
    bad_method = path.read_text().replace("SPC = ONE", "SPC = 1").replace("METHOD = 1",
                                                                        "METHOD = FIRST")
    m = build_model(read_deck(write(bad_method)))
    with pytest.raises(ModelError, match="case control METHOD = FIRST: expected a set id"):
        solve_normal_modes(m)
