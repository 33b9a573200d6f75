"""PBARL / PBEAML section library: areas against the QRG area formulas, inertias against a
brute-force integration over a fine grid of independently described shapes, torsion and shear
factors, dimension checks, the older types unchanged, and a bar model using a library section.

Geometry (y up, z to the right, as in femcal.properties.sections): L has its legs along +y and
+z from the corner, so I12 < 0; Z has its top flange on -z and its bottom flange on +z, so
I12 < 0; BOX1 has DIM5 on the right (+z) and DIM6 on the left.
"""

from __future__ import annotations

import numpy as np
import pytest

from femcal.deck import read_deck
from femcal.model.build import build_model
from femcal.properties.sections import section_properties, shear_factors
from femcal.solve.normal_modes import solve_normal_modes

NEW_TYPES = ["I", "I1", "CHAN", "CHAN1", "CHAN2", "T", "T1", "T2", "L", "H", "Z", "CROSS",
             "HAT", "BOX1"]  # fmt: skip
SYMMETRIC = [k for k in NEW_TYPES if k not in ("L", "Z", "BOX1")]


def valid_dims(kind: str, rng: np.random.Generator, n: int, thick: bool = False) -> np.ndarray:
    """n random valid dimension sets (DIM1, DIM2, ...); thick: walls at least ~10 % of the
    section, so a 2000 x 2000 grid resolves every wall with 200+ cells."""
    u = lambda lo, hi: rng.uniform(lo, hi, n)  # noqa: E731
    f = (lambda: u(0.15, 0.35)) if thick else (lambda: u(0.02, 0.4))
    if kind == "I":
        h, wb, wt = u(4, 10), u(2, 8), u(2, 8)
        return np.column_stack([h, wb, wt, f() * np.minimum(wb, wt), f() * h, f() * h])
    if kind in ("I1", "CHAN1", "Z"):  # outstand, web thickness, web clear height, height
        h = u(4, 10)
        return np.column_stack([u(1, 6), f() * 4, (1 - 2 * f()) * h, h])
    if kind == "CHAN":  # width, height, web, flanges
        b, h = u(2, 6), u(4, 10)
        return np.column_stack([b, h, f() * b, f() * h])
    if kind == "CHAN2":  # legs, base, height, width
        b, h = u(4, 10), u(2, 6)
        return np.column_stack([f() * b, f() * h, h, b])
    if kind in ("T", "T2", "L"):  # width, height, flange (horizontal) t, web (vertical) t
        b, h = u(2, 8), u(3, 10)
        return np.column_stack([b, h, f() * h, f() * b])
    if kind == "T1":  # upright height, arm length, upright t, arm t
        h, b = u(3, 10), u(2, 8)
        return np.column_stack([h, b, f() * b, f() * h])
    if kind == "H":  # web clear length, both flanges' t, height, web t
        h = u(3, 10)
        return np.column_stack([u(1, 6), f() * 6, h, f() * h])
    if kind == "CROSS":  # both arms, upright t, height, arm t
        b, h = u(2, 8), u(3, 10)
        return np.column_stack([b, f() * b, h, f() * h])
    if kind == "HAT":  # height, wall t, crown width, foot length
        h, w = u(3, 8), u(3, 8)
        return np.column_stack([h, f() * np.minimum(h, w), w, u(0.5, 3)])
    if kind == "BOX1":  # width, height, top, bottom, right, left
        b, h = u(3, 10), u(3, 10)
        return np.column_stack([b, h, f() * h / 2, f() * h / 2, f() * b / 2, f() * b / 2])
    raise AssertionError(kind)


def qrg_area(kind: str, d: np.ndarray) -> np.ndarray:
    """Area formulas of the QRG's PBARL remarks (as listed in pyNastran's bars.py); L is not
    in that list and uses pyNastran's l_section area."""
    D1, D2, D3, D4 = d[:, 0], d[:, 1], d[:, 2], d[:, 3]
    D5, D6 = (d[:, 4], d[:, 5]) if d.shape[1] > 4 else (None, None)
    return {
        "I": lambda: (D3 * D6) + (D2 * D5) + ((D1 - (D5 + D6)) * D4),
        "I1": lambda: (D2 * D3) + ((D4 - D3) * (D1 + D2)),
        "CHAN": lambda: (2 * (D1 * D4)) + ((D2 - (2 * D4)) * D3),
        "CHAN1": lambda: (D2 * D3) + ((D4 - D3) * (D1 + D2)),
        "CHAN2": lambda: 2 * (D1 * D3) + ((D4 - (2 * D1)) * D2),
        "T": lambda: (D1 * D3) + ((D2 - D3) * D4),
        "T1": lambda: (D1 * D3) + (D2 * D4),
        "T2": lambda: (D1 * D3) + ((D2 - D3) * D4),
        "BOX1": lambda: (D2 * D6) + (D2 * D5) + ((D1 - D5 - D6) * D3) + ((D1 - D5 - D6) * D4),
        "CROSS": lambda: (D2 * D3) + 2 * ((0.5 * D1) * D4),
        "H": lambda: 2 * ((0.5 * D2) * D3) + (D1 * D4),
        "Z": lambda: (D2 * D3) + ((D4 - D3) * (D1 + D2)),
        "HAT": lambda: (D2 * D3) + 2 * ((D1 - D2) * D2) + 2 * (D2 * D4),
        "L": lambda: D1 * D3 + (D2 - D3) * D4,
    }[kind]()


def bounding_box(kind: str, D) -> tuple[float, float, float, float]:
    """z0, z1, y0, y1 enclosing the section as placed by ``inside``."""
    D = list(D)
    if kind == "I":
        w = max(D[1], D[2]) / 2
        return -w, w, 0, D[0]
    if kind in ("I1", "Z"):
        w = D[0] + D[1] if kind == "Z" else (D[0] + D[1]) / 2
        return -w, w, -D[3] / 2, D[3] / 2
    if kind == "CHAN1":
        return 0, D[0] + D[1], -D[3] / 2, D[3] / 2
    if kind in ("CHAN", "L", "BOX1"):
        return 0, D[0], 0, D[1]
    if kind == "CHAN2":
        return -D[3] / 2, D[3] / 2, 0, D[2]
    if kind in ("T", "T2"):
        return -D[0] / 2, D[0] / 2, 0, D[1]
    if kind == "T1":
        return -D[1], D[2], -D[0] / 2, D[0] / 2
    if kind in ("H", "CROSS"):
        w = (D[0] + D[1]) / 2
        return -w, w, -D[2] / 2, D[2] / 2
    if kind == "HAT":
        w = D[2] / 2 + D[3]
        return -w, w, 0, D[0]
    raise AssertionError(kind)


def inside(kind: str, D, z: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Whether (z, y) lies in the section, described from the QRG figure directly (not from
    the rectangles the module uses)."""
    az, ay = abs(z), abs(y)
    if kind == "I":
        h, wb, wt, tw, tb, tt = D
        half = np.where(y < tb, wb / 2, np.where(y > h - tt, wt / 2, tw / 2))
        return (y >= 0) & (y <= h) & (az <= half)
    if kind == "I1":
        b, tw, hw, h = D
        return (ay <= h / 2) & (az <= np.where(ay > hw / 2, (b + tw) / 2, tw / 2))
    if kind == "CHAN":
        b, h, tw, tf = D
        flange = (y < tf) | (y > h - tf)
        return (y >= 0) & (y <= h) & (z >= 0) & (z <= np.where(flange, b, tw))
    if kind == "CHAN1":
        b, tw, hw, h = D
        return (ay <= h / 2) & (z >= 0) & (z <= np.where(ay > hw / 2, b + tw, tw))
    if kind == "CHAN2":
        tl, tb, h, b = D
        return (y >= 0) & (y <= h) & (az <= b / 2) & ((y <= tb) | (az >= b / 2 - tl))
    if kind in ("T", "T2"):
        b, h, tf, tw = D
        flange = (y >= h - tf) if kind == "T" else (y <= tf)
        return (y >= 0) & (y <= h) & (az <= np.where(flange, b / 2, tw / 2))
    if kind == "T1":
        h, b, tu, ta = D
        upright = (z >= 0) & (z <= tu) & (ay <= h / 2)
        return upright | ((z >= -b) & (z < 0) & (ay <= ta / 2))
    if kind == "L":
        b, h, th, tv = D
        return (z >= 0) & (y >= 0) & (((y <= th) & (z <= b)) | ((z <= tv) & (y <= h)))
    if kind == "H":
        bw, t2f, h, tw = D
        return (ay <= h / 2) & (az <= (bw + t2f) / 2) & ((az >= bw / 2) | (ay <= tw / 2))
    if kind == "Z":
        b, tw, hw, h = D
        w = tw / 2 + b
        top = (y >= hw / 2) & (z >= -w) & (z <= 0)
        bottom = (y <= -hw / 2) & (z <= w) & (z >= 0)
        return (ay <= h / 2) & ((az <= tw / 2) | top | bottom)
    if kind == "CROSS":
        b, tv, h, th = D
        return ((az <= tv / 2) & (ay <= h / 2)) | ((az <= (tv + b) / 2) & (ay <= th / 2))
    if kind == "HAT":
        h, t, w, f = D
        crown = (y >= h - t) & (az <= w / 2)
        legs = (az >= w / 2 - t) & (az <= w / 2)
        feet = (y <= t) & (az >= w / 2) & (az <= w / 2 + f)
        return (y >= 0) & (y <= h) & (crown | legs | feet)
    if kind == "BOX1":
        b, h, tt, tb, tr, tl = D
        hole = (z > tl) & (z < b - tr) & (y > tb) & (y < h - tt)
        return (z >= 0) & (z <= b) & (y >= 0) & (y <= h) & ~hole
    raise AssertionError(kind)


def grid_moments(kind: str, D, n: int = 2000) -> tuple[float, float, float, float]:
    """A, I1 (y^2), I2 (z^2), I12 (y z) about the centroid by the midpoint rule on n x n cells."""
    z0, z1, y0, y1 = bounding_box(kind, D)
    dz, dy = (z1 - z0) / n, (y1 - y0) / n
    z = z0 + dz * (np.arange(n) + 0.5)
    y = y0 + dy * (np.arange(n) + 0.5)
    M = inside(kind, D, z[None, :], y[:, None]).astype(float)  # rows y, columns z
    cells = M.sum()
    zb = (M.sum(axis=0) @ z) / cells
    yb = (M.sum(axis=1) @ y) / cells
    da = dz * dy
    i1 = (M.sum(axis=1) @ (y - yb) ** 2) * da
    i2 = (M.sum(axis=0) @ (z - zb) ** 2) * da
    i12 = ((y - yb) @ M @ (z - zb)) * da
    return cells * da, i1, i2, i12


@pytest.mark.parametrize("kind", NEW_TYPES)
def test_area_is_the_qrg_formula(kind):
    d = valid_dims(kind, np.random.default_rng(1), 50)
    props = section_properties(kind, d)
    assert props[:, 0] == pytest.approx(qrg_area(kind, d), rel=1e-12)


@pytest.mark.parametrize("kind", NEW_TYPES)
def test_inertias_match_a_grid_integration(kind):
    d = valid_dims(kind, np.random.default_rng(2), 1, thick=True)
    area, i1, i2, i12, _ = section_properties(kind, d)[0]
    g_area, g1, g2, g12 = grid_moments(kind, d[0])
    assert area == pytest.approx(g_area, rel=5e-3)
    assert i1 == pytest.approx(g1, rel=5e-3)
    assert i2 == pytest.approx(g2, rel=5e-3)
    assert abs(i12 - g12) <= 5e-3 * np.sqrt(i1 * i2)


def test_bwb_t2_section_by_hand():
    # T2 10 x 24, flange and web 1 thick (refdeck pyn_bwb): flange 10 x 1 at y = 0.5, web
    # 1 x 23 at y = 12.5; centroid (5 + 287.5) / 33; J = (10 * 1 + 23.5 * 1) / 3.
    area, i1, i2, i12, j = section_properties("T2", np.array([[10.0, 24.0, 1.0, 1.0]]))[0]
    yb = (10 * 0.5 + 23 * 12.5) / 33
    assert area == pytest.approx(33.0)
    assert i1 == pytest.approx(10 / 12 + 10 * (yb - 0.5) ** 2 + 23**3 / 12 + 23 * (12.5 - yb) ** 2)
    assert i2 == pytest.approx((1 * 1000 + 23 * 1) / 12)
    assert i12 == 0.0
    assert j == pytest.approx(33.5 / 3)
    assert shear_factors("T2", [10.0, 24.0, 1.0, 1.0])[0] == pytest.approx([23 / 33, 9 / 33])


@pytest.mark.parametrize("kind", SYMMETRIC)
def test_symmetric_sections_have_no_product_of_inertia(kind):
    d = valid_dims(kind, np.random.default_rng(3), 20)
    assert (section_properties(kind, d)[:, 3] == 0.0).all()


@pytest.mark.parametrize("kind", ["L", "Z"])
def test_l_and_z_product_of_inertia_is_negative(kind):
    # L: legs along +y and +z; Z: top flange on -z, bottom flange on +z (module docstring).
    props = section_properties(kind, valid_dims(kind, np.random.default_rng(4), 50))
    assert (props[:, 3] < 0).all()
    assert (props[:, 1] * props[:, 2] > props[:, 3] ** 2).all()


def test_box1_with_equal_walls_is_box():
    rng = np.random.default_rng(5)
    b, h = rng.uniform(3, 10, 20), rng.uniform(3, 10, 20)
    t1, t2 = rng.uniform(0.02, 0.4, 20) * h / 2, rng.uniform(0.02, 0.4, 20) * b / 2
    box1 = np.column_stack([b, h, t1, t1, t2, t2])
    box = np.column_stack([b, h, t1, t2])
    p1, p = section_properties("BOX1", box1), section_properties("BOX", box)
    assert np.abs(p1[:, 3]).max() <= 1e-12 * np.abs(p[:, 1]).max()
    assert np.allclose(p1[:, [0, 1, 2, 4]], p[:, [0, 1, 2, 4]], rtol=1e-12, atol=0)
    assert np.allclose(shear_factors("BOX1", box1), shear_factors("BOX", box), rtol=1e-12)


def test_box1_unequal_walls_sign():
    # heavier bottom and left walls: material towards (-y, -z) from the centroid, I12 < 0;
    # mirrored left-right (DIM5 <-> DIM6) it changes sign
    d = np.array([[6.0, 8.0, 1.0, 1.5, 0.5, 1.0]])
    i12 = section_properties("BOX1", d)[0, 3]
    mirrored = section_properties("BOX1", d[:, [0, 1, 2, 3, 5, 4]])[0, 3]
    assert i12 < 0 and mirrored == pytest.approx(-i12)
    assert i12 == pytest.approx(grid_moments("BOX1", d[0])[3], rel=5e-3)


#: Thin-walled versions (every wall e thick) and the total length of their walls.
THIN = {
    "I": (lambda e: [10, 6, 8, e, e, e], 24),
    "I1": (lambda e: [4, e, 10 - 2 * e, 10], 18),
    "CHAN": (lambda e: [4, 10, e, e], 18),
    "CHAN1": (lambda e: [4, e, 10 - 2 * e, 10], 18),
    "CHAN2": (lambda e: [e, e, 5, 8], 18),
    "T": (lambda e: [6, 8, e, e], 14),
    "T1": (lambda e: [8, 4, e, e], 12),
    "T2": (lambda e: [6, 8, e, e], 14),
    "L": (lambda e: [5, 8, e, e], 13),
    "H": (lambda e: [6, 2 * e, 8, e], 22),
    "Z": (lambda e: [3, e, 10 - 2 * e, 10], 16),
    "CROSS": (lambda e: [6, e, 8, e], 14),
    "HAT": (lambda e: [5, e, 6, 2], 20),
}


@pytest.mark.parametrize("kind", list(THIN))
def test_thin_wall_torsion_tends_to_sum_b_t3_over_3(kind):
    dims, length = THIN[kind]
    errors = []
    for e in (1e-2, 1e-3, 1e-4):
        J = section_properties(kind, np.array([dims(e)], dtype=float))[0, 4]
        errors.append(abs(J / (length * e**3 / 3) - 1))
    assert errors[1] < 5e-3 and errors[2] < 5e-4
    assert errors[2] <= errors[1] + 1e-9 <= errors[0] + 2e-9  # exact for CHAN1 and Z


def test_box1_torsion_is_bredt_batho():
    # closed thin-walled: J = 4 Am^2 / (sum of s / t) on the mid-line
    b, h, tt, tb, tr, tl = 6.0, 8.0, 0.1, 0.2, 0.05, 0.15
    bm, hm = b - (tr + tl) / 2, h - (tt + tb) / 2
    j = section_properties("BOX1", [b, h, tt, tb, tr, tl])[0, 4]
    assert j == pytest.approx(4 * (bm * hm) ** 2 / (bm / tt + bm / tb + hm / tr + hm / tl))


@pytest.mark.parametrize("kind", NEW_TYPES)
def test_shear_factors_are_wall_fractions(kind):
    d = valid_dims(kind, np.random.default_rng(6), 30)
    k = shear_factors(kind, d)
    assert k.shape == (30, 2)
    assert (k > 0).all() and (k.sum(axis=1) < 1).all()


def test_l_and_chan_shear_factors_are_the_reference_manual_values():
    # MSC Reference Manual beam library (quoted in pyNastran): L k1 = h2 t2 / A,
    # k2 = b1 t1 / A; CHAN k1 = tw hw / A, k2 = 2 tf bf / A.
    L = [5.0, 8.0, 1.0, 1.5]
    A = 5 * 1 + 7 * 1.5
    assert shear_factors("L", L)[0] == pytest.approx([7 * 1.5 / A, 3.5 * 1 / A])
    C = [4.0, 10.0, 1.0, 1.5]
    A = 10 * 1 + 2 * 3 * 1.5
    assert shear_factors("CHAN", C)[0] == pytest.approx([7 * 1 / A, 2 * 1.5 * 3 / A])


@pytest.mark.parametrize("kind", NEW_TYPES)
def test_many_elements_at_once_match_one_by_one(kind):
    d = valid_dims(kind, np.random.default_rng(7), 5)
    together = section_properties(kind, d)
    alone = np.vstack([section_properties(kind, row) for row in d])
    assert np.allclose(together, alone, rtol=1e-14, atol=0)


#: One invalid set per type: a wall as thick as the section (or thicker).
INVALID = {
    "I": [10, 6, 8, 1, 5, 5],
    "I1": [4, 1, 10, 10],
    "CHAN": [4, 10, 1, 5],
    "CHAN1": [4, 1, 12, 10],
    "CHAN2": [4, 1, 5, 8],
    "T": [6, 8, 8, 1],
    "T1": [8, 4, 1, 9],
    "T2": [6, 8, 1, 6],
    "L": [5, 8, 1, 5],
    "H": [6, 2, 8, 8],
    "Z": [3, 1, 11, 10],
    "CROSS": [6, 1, 8, 9],
    "HAT": [5, 3, 6, 2],
    "BOX1": [6, 8, 1, 1, 3, 3],
}


@pytest.mark.parametrize("kind", NEW_TYPES)
def test_invalid_dimensions_raise(kind):
    with pytest.raises(ValueError, match=rf"^{kind} section needs .*entries \[0\]"):
        section_properties(kind, np.array([INVALID[kind]], dtype=float))
    good = valid_dims(kind, np.random.default_rng(8), 3)
    good[1, 0] = -good[1, 0]
    with pytest.raises(ValueError, match=rf"{kind} section needs all dimensions positive"):
        section_properties(kind, good)
    with pytest.raises(ValueError, match=f"{kind} section needs"):
        section_properties(kind, good[:, :2])


def test_unsupported_type_lists_the_supported_ones():
    with pytest.raises(ValueError, match=r"DBOX is not supported.*BOX1"):
        section_properties("DBOX", np.ones((1, 10)))


# Values of ROD, TUBE, TUBE2, BAR and BOX computed by the code before the library was
# extended; they must not change.
OLD = {
    "ROD": ([[0.5], [2.0]],
            [[0.7853981633974483, 0.04908738521234052, 0.04908738521234052, 0.0, 0.09817477042468103],
             [12.566370614359172, 12.566370614359172, 12.566370614359172, 0.0, 25.132741228718345]],
            [[0.9, 0.9], [0.9, 0.9]]),
    "TUBE": ([[1.0, 0.8], [0.3, 0.05]],
             [[1.1309733552923251, 0.4636990756698534, 0.4636990756698534, 0.0, 0.9273981513397068],
              [0.2748893571891069, 0.006356816384998095, 0.006356816384998095, 0.0, 0.01271363276999619]],
             [[0.5, 0.5], [0.5, 0.5]]),
    "TUBE2": ([[1.0, 0.2], [0.3, 0.25]],
              [[1.1309733552923251, 0.4636990756698534, 0.4636990756698534, 0.0, 0.9273981513397068],
               [0.2748893571891069, 0.006356816384998095, 0.006356816384998095, 0.0, 0.01271363276999619]],
              [[0.5, 0.5], [0.5, 0.5]]),
    "BAR": ([[0.1, 0.1], [2.0, 0.5]],
            [[0.010000000000000002, 8.333333333333335e-06, 8.333333333333335e-06, 0.0, 1.4083333333333338e-05],
             [1.0, 0.020833333333333332, 0.3333333333333333, 0.0, 0.07021260579427083]],
            [[0.8333333333333334, 0.8333333333333334], [0.8333333333333334, 0.8333333333333334]]),
    "BOX": ([[0.6, 0.2, 0.0025, 0.0025], [2.0, 3.0, 0.1, 0.3]],
            [[0.003974999999999992, 3.234578125000013e-05, 0.00017702078124999984, 0.0, 8.758160401926101e-05],
             [2.0800000000000005, 1.938933333333334, 1.3597333333333335, 0.0, 1.8228674999999999]],
            [[0.245283018867925, 0.7484276729559762], [0.8076923076923075, 0.13461538461538458]]),
}  # fmt: skip


@pytest.mark.parametrize("kind", list(OLD))
def test_existing_types_unchanged(kind):
    """Unchanged to a few units in the last place: the formulas pass through libm (pi,
    powers) and NumPy's SIMD loops, whose last bit differs between processors (a TUBE's I
    ends ...097 on one, ...095 on another), so 1e-13 relative, not bit for bit."""
    dims, props, k = OLD[kind]
    np.testing.assert_allclose(section_properties(kind, np.array(dims)), props, rtol=1e-13,
                               atol=0)  # fmt: skip
    np.testing.assert_allclose(shear_factors(kind, np.array(dims)), k, rtol=1e-13, atol=0)


def test_pbarl_l_bar_model_equals_pbar_with_its_properties(write):
    # A cantilever of CBARs with a PBARL L section has the modes of the same cantilever with
    # a PBAR holding that section's A, I1, I2, J, K1, K2 and I12 (K1 and K2 ignored by both,
    # as the Guide says of a bar with an I12).
    dims = [30.0, 50.0, 4.0, 3.0]
    A, I1, I2, I12, J = section_properties("L", dims)[0].tolist()
    K1, K2 = shear_factors("L", dims)[0].tolist()
    n, L = 10, 1000.0
    grids = "\n".join(f"GRID,{i + 1},,{L * i / n},0.,0." for i in range(n + 1))
    bars = "\n".join(f"CBAR,{i + 1},1,{i + 1},{i + 2},0.,1.,0." for i in range(n))
    common = (f"SOL 103\nCEND\nMETHOD = 1\nSPC = 1\nBEGIN BULK\nEIGRL,1,,,6\n{grids}\n{bars}\n"
              "MAT1,1,2.1+5,,.3,7.85-9\nSPC1,1,123456,1\n")  # fmt: skip
    pbarl = "PBARL,1,1,,L\n,30.,50.,4.,3.\n"
    pbar = (f"PBAR,1,1,{A!r},{I1!r},{I2!r},{J!r}\n,0.,0.,0.,0.,0.,0.,0.,0.\n"
            f",{K1!r},{K2!r},{I12!r}\n")  # fmt: skip
    freqs = []
    for prop, name in ((pbarl, "pbarl.bdf"), (pbar, "pbar.bdf")):
        deck = read_deck(write(common + prop + "ENDDATA\n", name))
        modes, _ = solve_normal_modes(build_model(deck))
        freqs.append(modes.frequencies_hz[:6])
    assert np.all(freqs[0] > 0)
    assert freqs[0] == pytest.approx(freqs[1], rel=1e-9)
