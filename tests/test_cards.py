"""Cards: every field read, and the Quick Reference Guide's defaults applied."""

import math

import pytest

from femcal.deck import read_deck
from femcal.errors import DeckError
from femcal.markers import INT_BLANK

HEAD = "SOL 103\nCEND\nBEGIN BULK\n"


def one(write, text, card):
    d = read_deck(write(HEAD + text))
    t = d.table(card).columns
    return {k: (v[0].item() if hasattr(v[0], "item") else v[0]) for k, v in t.items()}


def rec(write, text, card):
    d = read_deck(write(HEAD + text))
    return d.records_of(card)[0]


def test_grid_defaults(write):
    g = one(write, "GRID    5\n", "GRID")
    assert (g["x1"], g["x2"], g["x3"]) == (0.0, 0.0, 0.0)
    assert g["cp"] == INT_BLANK and g["cd"] == INT_BLANK and g["ps"] == INT_BLANK


def test_cquad4_pid_defaults_to_eid_and_theta_or_mcid(write):
    q = one(write, "CQUAD4  7               1       2       3       4       30.     .5\n", "CQUAD4")
    assert q["pid"] == 7 and q["theta"] == 30.0 and q["mcid"] == INT_BLANK and q["zoffs"] == 0.5
    q = one(write, "CQUAD4  7       2       1       2       3       4       5\n", "CQUAD4")
    assert q["mcid"] == 5 and math.isnan(q["theta"]) and q["pid"] == 2


def test_cquad4_thickness_continuation(write):
    """The continuation as the Quick Reference Guide lays it out: field 2 blank, TFLAG in
    field 3, T1-T4 in fields 4-7 (pyNastran reads it so too)."""
    q = one(
        write,
        "CQUAD4  1       1       1       2       3       4\n"
        "                1       .1      .2      .3      .4\n",
        "CQUAD4",
    )
    assert (q["tflag"], q["t1"], q["t4"]) == (1, 0.1, 0.4)


def test_ctria3_thickness_continuation(write):
    t = one(
        write,
        "CTRIA3  1       1       1       2       3       0.      .05\n"
        "                0       .1      .2      .3\n",
        "CTRIA3",
    )
    assert (t["zoffs"], t["tflag"], t["t1"], t["t3"]) == (0.05, 0, 0.1, 0.3)


def test_pshell_defaults(write):
    p = one(write, "PSHELL  1       2       .1      2\n", "PSHELL")
    assert p["bk"] == 1.0 and p["tst"] == 0.833333 and p["nsm"] == 0.0
    assert p["mid3"] == INT_BLANK and math.isnan(p["z1"])


def test_cbar_vector_and_g0(write):
    b = one(write, "CBAR    1       2       3       4       0.      1.      0.\n", "CBAR")
    assert b["g0"] == INT_BLANK and (b["x1"], b["x2"], b["x3"]) == (0.0, 1.0, 0.0)
    b = one(write, "CBAR    1       2       3       4       9\n", "CBAR")
    assert b["g0"] == 9 and math.isnan(b["x1"])
    assert b["offt"] == "" and b["pa"] == INT_BLANK and b["w1a"] == 0.0


def test_cbeam_offt_or_bit_and_warping(write):
    b = one(
        write,
        "CBEAM   1       2       3       4       0.      1.      0.      1.5\n"
        "+\n"
        "        7       8\n",
        "CBEAM",
    )
    assert b["bit"] == 1.5 and b["offt"] == "" and (b["sa"], b["sb"]) == (7, 8)


def test_conm2_and_celas_and_cbush_defaults(write):
    m = one(write, "CONM2   1       2               3.\n", "CONM2")
    assert m["cid"] == 0 and m["m"] == 3.0 and m["i11"] == 0.0
    e = one(write, "CELAS1  4               1       3\n", "CELAS1")
    assert e["pid"] == 4 and e["c1"] == 3 and e["g2"] == INT_BLANK
    b = one(write, "CBUSH   1       2       3\n", "CBUSH")
    assert b["s"] == 0.5 and b["ocid"] == -1 and b["gb"] == INT_BLANK


def test_mat1_blank_fields_stay_blank_for_the_model(write):
    m = one(write, "MAT1    1       2.1+5           .3      7.85-9\n", "MAT1")
    assert m["e"] == 210000.0 and math.isnan(m["g"]) and m["nu"] == 0.3 and m["rho"] == 7.85e-9


def test_multi_entry_cards(write):
    d = read_deck(
        write(
            HEAD
            + "PELAS   1       10.                     2       20.\nSPC     1       2       123     "
            "        3       456     .5\nPMASS   1       .1      2       .2      3       .3\n"
        )
    )
    assert d.table("PELAS")["k"].tolist() == [10.0, 20.0]
    spc = d.table("SPC").columns
    assert (
        spc["g"].tolist() == [2, 3]
        and spc["c"].tolist() == [123, 456]
        and spc["d"].tolist() == [0.0, 0.5]
    )
    assert d.table("PMASS")["pid"].tolist() == [1, 2, 3]
    assert d.card_count == {"PELAS": 1, "SPC": 1, "PMASS": 1}


def test_spoint_and_spc1_thru(write):
    d = read_deck(
        write(
            HEAD
            + "SPOINT  1       THRU    4\nSPOINT  10      12\nSPC1    3       123     5       THRU    8\n"
        )
    )
    assert [r.ids for r in d.records_of("SPOINT")] == [(1, 2, 3, 4), (10, 12)]
    s = d.records_of("SPC1")[0]
    assert (s.sid, s.components, s.ids, s.ranges) == (3, 123, (), ((5, 8),))


def test_rbe2_with_alpha(write):
    r = rec(
        write,
        "RBE2    9       1       123456  2       3       4       5       6\n"
        "        7       8       1.-5\n",
        "RBE2",
    )
    assert (r.eid, r.gn, r.cm, r.gm, r.alpha) == (9, 1, 123456, (2, 3, 4, 5, 6, 7, 8), 1e-5)


def test_rbe3_groups_um_and_alpha(write):
    r = rec(
        write,
        "RBE3    5               10      123456  1.      123     1       2\n"
        "        3       .5      12      4\n"
        "        UM      1       1       2       2\n"
        "        ALPHA   2.-6\n",
        "RBE3",
    )
    assert r.refgrid == 10 and r.refc == 123456
    assert [(g.weight, g.components, g.grids) for g in r.groups] == [
        (1.0, 123, (1, 2, 3)),
        (0.5, 12, (4,)),
    ]
    assert r.um == ((1, 1), (2, 2)) and r.alpha == 2e-6


def test_mpc_terms(write):
    r = rec(
        write,
        "MPC     1       2       1       1.      3       2       -1.\n"
        "                4       3       .5\n",
        "MPC",
    )
    assert r.terms == ((2, 1, 1.0), (3, 2, -1.0), (4, 3, 0.5))


def test_pcomp_blank_mid_and_t_repeat_previous_ply(write):
    r = rec(
        write,
        "PCOMP   1                                                       SYM\n"
        "        2       .1      0.      YES             .2      45.\n"
        "                        90.\n",
        "PCOMP",
    )
    assert [(p.mid, p.t, p.theta, p.sout) for p in r.plies] == [
        (2, 0.1, 0.0, "YES"),
        (2, 0.2, 45.0, "NO"),
        (2, 0.2, 90.0, "NO"),
    ]
    assert r.lam == "SYM" and math.isnan(r.z0)


def test_pcompg(write):
    r = rec(
        write,
        "PCOMPG  1\n        101     2       .1      30.\n        102     3       .2\n",
        "PCOMPG",
    )
    assert [(p.gplyid, p.mid, p.t) for p in r.plies] == [(101, 2, 0.1), (102, 3, 0.2)]


def test_pbarl_default_group_and_dims(write):
    r = rec(
        write,
        "PBARL   1       2               I\n        10.     8.      1.      1.      .5      .5      .1\n",
        "PBARL",
    )
    assert r.group == "MSCBML0" and r.dims == (10.0, 8.0, 1.0, 1.0, 0.5, 0.5) and r.nsm == 0.1


def test_pbarl_wrong_dimension_count(write):
    with pytest.raises(DeckError, match="nothing after NSM"):
        read_deck(write(HEAD + "PBARL   1       2               ROD\n        1.      0.      5.\n"))


def test_pbeaml_tapered(write):
    r = rec(
        write,
        "PBEAML  1       1               TUBE\n         .2      .195            YES     1.      .4      .395\n",
        "PBEAML",
    )
    assert [(s.x, s.dims) for s in r.stations] == [(0.0, (0.2, 0.195)), (1.0, (0.4, 0.395))]


def test_pbeam_stations_and_tail(write):
    # Layout of refdecks/cofe_three_element_types: end A, stress points, a YESA station, K1 K2.
    r = rec(
        write,
        "PBEAM          1     501    800.106666.726666.67      0.73270.28      0.\n"
        "+           -20.    -10.     20.    -10.     20.     10.    -20.     10.\n"
        "+           YESA      1.\n"
        "+       .8499302.8507011\n",
        "PBEAM",
    )
    assert [s.so for s in r.stations] == ["YES", "YESA"]
    assert r.stations[1].a == 800.0 and r.stations[0].stress_points[0] == -20.0
    assert r.tail_value("k1") == 0.8499302 and r.tail_value("k2") == 0.8507011


def test_pbush_keywords(write):
    r = rec(
        write, "PBUSH   1       K       1.      2.      3.\n                B       .1\n", "PBUSH"
    )
    assert r.k == (1.0, 2.0, 3.0, 0.0, 0.0, 0.0) and r.b[0] == 0.1 and r.given == ("K", "B")


def test_param_and_eigrl(write):
    d = read_deck(
        write(
            HEAD + "PARAM   WTMASS  .00259\nPARAM,AUTOSPC,YES\nEIGRL   1               100.    10\n"
        )
    )
    assert d.param("WTMASS") == 0.00259 and d.param("AUTOSPC") == "YES"
    e = d.records_of("EIGRL")[0]
    assert (e.sid, e.v2, e.nd, e.norm) == (1, 100.0, 10, "MASS") and math.isnan(e.v1)


def test_cord_cards(write):
    d = read_deck(
        write(
            HEAD + "CORD2C  3       0       0.      0.      0.      0.      0.      1.\n"
            "        1.      0.      0.\nCORD1R  4       1       2       3\n"
        )
    )
    c = d.table("CORD2C").columns
    assert c["cid"][0] == 3 and c["b3"][0] == 1.0 and c["c1"][0] == 1.0
    assert d.table("CORD1R")["g3"].tolist() == [3]


def test_solid_node_counts(write):
    d = read_deck(
        write(
            HEAD + "CTETRA  1       2       1       2       3       4\n"
            "CHEXA   2       2       1       2       3       4       5       6\n        7       8\n"
        )
    )
    assert d.table("CHEXA")["g8"][0] == 8 and d.table("CHEXA")["g9"][0] == INT_BLANK
    with pytest.raises(DeckError, match="G4"):
        read_deck(write(HEAD + "CTETRA  1       2       1       2       3\n"))
