"""Sparse assembly: the pattern and the scatter agree with a dense reference assembly."""

from __future__ import annotations

import numpy as np
import pytest

from femcal.assembly.pattern import Assembler, Pattern


def rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q * np.sign(np.linalg.det(q))


def test_pattern_and_scatter_match_dense_assembly():
    rng = np.random.default_rng(1)
    ndof = np.array([6, 1, 6, 6, 1, 6])
    dof_start = np.concatenate([[0], np.cumsum(ndof)[:-1]])
    n_dof = int(ndof.sum())
    grid_nodes = np.flatnonzero(ndof == 6)
    elems = np.array([[0, 2], [2, 3], [3, 5], [5, 0]])
    pattern = Pattern.build(dof_start, ndof, [elems, np.array([[1, 4], [4, 0], [1, 5]])])
    frames = np.tile(np.eye(3), (6, 1, 1))
    frames[3] = rotation(rng)
    frames[5] = rotation(rng)
    asm = Assembler(pattern, frames)
    mats = rng.normal(size=(len(elems), 12, 12))
    mats = mats + np.swapaxes(mats, 1, 2)
    asm.add_blocks(elems, 6, mats)
    asm.add_entries(np.array([6, 6, 25]), np.array([6, 25, 0]), np.array([1.0, -2.0, 3.0]))
    K = asm.matrix().toarray()
    dense = np.zeros((n_dof, n_dof))
    for (a, b), m in zip(elems, mats, strict=True):
        lam = np.zeros((12, 12))
        for j, node in enumerate((a, b)):
            for g in range(2):
                lam[6 * j + 3 * g : 6 * j + 3 * g + 3, 6 * j + 3 * g : 6 * j + 3 * g + 3] = frames[node]
        mk = lam.T @ m @ lam
        idx = np.r_[dof_start[a] : dof_start[a] + 6, dof_start[b] : dof_start[b] + 6]
        dense[np.ix_(idx, idx)] += mk
    dense[6, 6] += 1.0
    dense[6, 25] += -2.0
    dense[25, 0] += 3.0
    assert np.allclose(K, dense, atol=1e-12)
    assert grid_nodes.tolist() == [0, 2, 3, 5]
    # pattern: sorted columns per row, diagonal present, symmetric structure
    csr = asm.matrix()
    assert csr.has_sorted_indices
    pat = np.zeros((n_dof, n_dof), bool)
    for r in range(n_dof):
        pat[r, pattern.indices[pattern.indptr[r] : pattern.indptr[r + 1]]] = True
    assert (pat == pat.T).all() and pat.diagonal().all()


def test_absent_nodes_are_dropped_and_solid_blocks_use_translations():
    ndof = np.array([6, 6, 6])
    dof_start = np.array([0, 6, 12])
    elems = np.array([[0, 1, -1], [1, 2, 0]])
    pattern = Pattern.build(dof_start, ndof, [elems[:, [0, 1]], elems[:, [1, 2]], elems[:, [0, 2]]])
    asm = Assembler(pattern)
    mats = np.ones((2, 9, 9))
    asm.add_blocks(elems, 3, mats)
    K = asm.matrix().toarray()
    assert K[0, 6] == 2.0 and K[0, 3] == 0.0 and K[12, 0] == 1.0 and K.sum() == 36 + 81  # 2 present nodes x 3 DOF, then 3 x 3


def test_entry_outside_the_pattern_is_refused():
    pattern = Pattern.build(np.array([0, 6]), np.array([6, 6]), [])
    asm = Assembler(pattern)
    try:
        asm.add_entries(np.array([0]), np.array([7]), np.array([1.0]))
    except ValueError as e:
        assert "not in the sparsity pattern" in str(e)
    else:
        raise AssertionError("an entry outside the pattern was accepted")


def test_compact_drops_stored_zeros_and_keeps_empty_rows():
    import scipy.sparse as sp

    from femcal.assembly.matrices import _compact

    A = sp.csr_matrix(np.array([[1.0, 0, 2], [0, 0, 0], [0, 0, 3.0]]))
    A.data[0] = 0.0  # a stored zero in row 0; row 1 has no entries at all
    B = _compact(A)
    assert B.nnz == 2 and np.array_equal(B.toarray(), A.toarray())
    R = sp.random(60, 60, density=0.2, format="csr", random_state=3)
    R.data[::4] = 0.0
    C = _compact(R)
    assert C.nnz == int((R.data != 0).sum()) and abs(C - R).max() == 0.0


def reference_pattern(dof_start, ndof, pairs):
    """CSR pattern by brute force: a dense boolean node graph expanded to DOF."""
    n = len(ndof)
    graph = np.eye(n, dtype=bool)
    for a, b in pairs:
        graph[a, b] = graph[b, a] = True
    n_dof = int(ndof.sum())
    dense = np.zeros((n_dof, n_dof), bool)
    for a, b in zip(*np.nonzero(graph), strict=True):
        dense[dof_start[a] : dof_start[a] + ndof[a], dof_start[b] : dof_start[b] + ndof[b]] = True
    import scipy.sparse as sp

    return sp.csr_matrix(dense)


@pytest.mark.parametrize("nodes_per_pass", [1, 2, 3, 5, 4096])
def test_pattern_is_the_same_whatever_the_expansion_pass_size(monkeypatch, nodes_per_pass):
    import femcal.assembly.pattern

    monkeypatch.setattr(femcal.assembly.pattern, "_EXPAND_NODES", nodes_per_pass)
    rng = np.random.default_rng(7)
    ndof = rng.choice([1, 6], size=23, p=[0.3, 0.7])
    dof_start = np.concatenate([[0], np.cumsum(ndof)[:-1]])
    pairs = rng.integers(0, 23, size=(40, 2))
    pairs = pairs[pairs[:, 0] != pairs[:, 1]]
    ref = reference_pattern(dof_start, ndof, pairs)
    for background in (False, True):  # indices computed here or in a thread
        pattern = Pattern.build(dof_start, ndof, [pairs], background=background)
        assert np.array_equal(pattern.indptr, ref.indptr)
        assert np.array_equal(pattern.indices, ref.indices)


def test_threaded_assembly_gives_bitwise_the_same_matrices(monkeypatch):
    """Kernels on worker threads, scatter in order: the sums do not depend on the thread
    count (shells and solids in small chunks, so that many run at once)."""
    import femcal.assembly.context as context
    from femcal.assembly import Options, assemble
    from femcal.deck import read_deck
    from femcal.model.build import build_model

    from .conftest import REFDECKS

    deck = REFDECKS / "pyn_mode_solid_shell_bar" / "mode_solid_shell_bar.bdf"
    model = build_model(read_deck(deck))
    assert {"CQUAD4", "CHEXA"} <= set(model.elements)
    monkeypatch.setattr(context, "KERNEL_CHUNK", 1)
    one = assemble(model, Options(threads=1))
    three = assemble(model, Options(threads=3))
    for a, b in ((one.K, three.K), (one.M, three.M)):
        assert np.array_equal(a.indptr, b.indptr) and np.array_equal(a.indices, b.indices)
        # the same element arithmetic on the same chunks, in another thread: equal to the
        # rounding of one entry (a SIMD path may depend on an array's alignment)
        np.testing.assert_allclose(a.data, b.data, rtol=1e-14, atol=1e-14 * np.abs(a.data).max())
    assert one.element_mass == pytest.approx(three.element_mass, rel=1e-14)


@pytest.mark.parametrize(
    ("corner", "what"),
    [((2.05, 0.05), "Jacobian"), ((1.5, 0.5), "degenerate")],  # concave; diagonals parallel
)
def test_bad_shell_is_reported_by_element_id_with_threads(monkeypatch, write, corner, what):
    import femcal.assembly.context as context
    from femcal.assembly import Options, assemble
    from femcal.deck import read_deck
    from femcal.errors import ModelError
    from femcal.model.build import build_model

    xy = [(0, 0), (1, 0), (1, 1), (0, 1), (2, 0), (2, 1), (3, 0), corner]
    grids = "".join(f"GRID,{i + 1},,{x:.2f},{y:.2f},0.\n" for i, (x, y) in enumerate(xy))
    deck = write(
        "BEGIN BULK\nPSHELL,1,1,0.1,1\nMAT1,1,2.1e5,,0.3,7.85e-9\n" + grids
        + "CQUAD4,11,1,1,2,3,4\nCQUAD4,12,1,2,5,6,3\nCQUAD4,13,1,5,7,8,6\n"
        + "ENDDATA\n"
    )  # fmt: skip
    model = build_model(read_deck(deck))
    monkeypatch.setattr(context, "KERNEL_CHUNK", 1)
    with pytest.raises(ModelError, match=rf"CQUAD4: .*{what}.*element ids \[13\]"):
        assemble(model, Options(threads=2))


def test_distorted_solid_is_reported_by_element_id(write):
    # a TETRA10 whose midside node (GRID 8, edge 1-4) is pulled past its corner: the
    # Jacobian changes sign inside it, and the error names element 22, not a position
    from femcal.assembly import assemble
    from femcal.deck import read_deck
    from femcal.errors import ModelError
    from femcal.model.build import build_model

    xyz = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (0.5, 0, 0), (0.5, 0.5, 0), (0, 0.5, 0),
           (0, 0, 1.4), (0.5, 0, 0.5), (0, 0.5, 0.5)]  # fmt: skip
    grids = "".join(f"GRID,{i + 1},,{x:.2f},{y:.2f},{z:.2f}\n" for i, (x, y, z) in enumerate(xyz))
    deck = write(
        "BEGIN BULK\nPSOLID,1,1\nMAT1,1,2.1e5,,0.3,7.85e-9\n" + grids
        + "CTETRA,22,1,1,2,3,4,5,6,+\n+,7,8,9,10\nENDDATA\n"
    )  # fmt: skip
    with pytest.raises(ModelError, match=r"Jacobian changes sign inside the elements at "
                                         r"element ids \[22\]"):  # fmt: skip
        assemble(build_model(read_deck(deck)))


def test_node_diagonal_blocks_are_summed_apart_and_equal_the_full_scatter():
    """Lumped (node-diagonal) element matrices go to per-node blocks; mixed with coupled ones
    and single entries, the matrix equals a dense assembly, in rotated frames too."""
    rng = np.random.default_rng(3)
    ndof = np.array([6, 6, 1, 6])
    dof_start = np.concatenate([[0], np.cumsum(ndof)[:-1]])
    elems = np.array([[0, 1], [1, 3], [3, 0]])
    pattern = Pattern.build(dof_start, ndof, [elems])
    frames = np.tile(np.eye(3), (4, 1, 1))
    frames[1] = rotation(rng)
    lumped = np.zeros((3, 12, 12))
    for e in range(3):
        for a in range(2):
            blk = rng.normal(size=(6, 6))
            lumped[e, 6 * a : 6 * a + 6, 6 * a : 6 * a + 6] = blk + blk.T
    coupled = rng.normal(size=(3, 12, 12))
    coupled = coupled + np.swapaxes(coupled, 1, 2)
    solid = np.zeros((2, 6, 6))  # 3 DOF per node, node-diagonal
    solid[:, :3, :3] = np.eye(3)
    solid[:, 3:, 3:] = 2 * np.eye(3)

    def assemble(parts):
        asm = Assembler(pattern, frames)
        for nodes, d, m in parts:
            asm.add_blocks(nodes, d, m)
        asm.add_entries(np.array([12]), np.array([12]), np.array([5.0]))  # the scalar point
        return asm.matrix().toarray()

    def dense(parts):
        out = np.zeros((19, 19))
        out[12, 12] = 5.0
        for nodes, d, mats in parts:
            for nd, m in zip(nodes, mats, strict=True):
                lam = np.zeros((len(nd) * d, len(nd) * d))
                idx = []
                for j, node in enumerate(nd):
                    for g in range(d // 3):
                        lam[d * j + 3 * g : d * j + 3 * g + 3, d * j + 3 * g : d * j + 3 * g + 3] = frames[node]  # fmt: skip
                    idx += list(range(dof_start[node], dof_start[node] + d))
                out[np.ix_(idx, idx)] += lam.T @ m @ lam
        return out

    only_lumped = [(elems, 6, lumped), (elems[:2], 3, solid)]
    mixed = [*only_lumped, (elems, 6, coupled)]
    for parts in (only_lumped, mixed):
        assert np.allclose(assemble(parts), dense(parts), atol=1e-12)


def test_a_model_without_nodes_is_an_error_not_a_crash(write):
    from femcal.assembly import assemble
    from femcal.errors import ModelError
    from femcal.model.build import load_model

    model = load_model(write("BEGIN BULK\nMAT1,1,2.1e5,,0.3,7.85e-9\nENDDATA\n"))
    with pytest.raises(ModelError, match="the model has no grids or scalar points"):
        assemble(model)


def test_a_bar_along_its_orientation_vector_is_named_not_a_traceback(write):
    from femcal.assembly import assemble
    from femcal.errors import ModelError
    from femcal.model.build import load_model

    model = load_model(write(
        "BEGIN BULK\nMAT1,1,2.1e5,,0.3,7.85e-9\nPBAR,1,1,1.,1.,1.,1.\nGRID,1,,0.,0.,0.\n"
        "GRID,2,,1.,0.,0.\nGRID,3,,1.,1.,0.\nCBAR,7,1,1,2,0.,1.,0.\nCBAR,8,1,2,3,0.,1.,0.\n"
        "ENDDATA\n"))  # fmt: skip
    with pytest.raises(ModelError, match=r"CBAR: .*parallel.*element ids \[8\]"):
        assemble(model)


@pytest.mark.parametrize("nodes_per_pass", [1, 3, 4096])
def test_pattern_of_a_few_nodes_holds_their_rows_only(monkeypatch, nodes_per_pass):
    """A pattern with the diagonal blocks of some nodes only (a few elements of a large
    model): the rows of the other nodes are empty, the rest as the reference pattern."""
    import femcal.assembly.pattern

    monkeypatch.setattr(femcal.assembly.pattern, "_EXPAND_NODES", nodes_per_pass)
    rng = np.random.default_rng(11)
    ndof = rng.choice([1, 6], size=30, p=[0.3, 0.7])
    dof_start = np.concatenate([[0], np.cumsum(ndof)[:-1]])
    pairs = np.array([[3, 8], [8, 17], [17, 3], [25, 26]])
    touched = np.unique(pairs)
    pattern = Pattern.build(dof_start, ndof, [pairs], diagonal=touched)
    full = reference_pattern(dof_start, ndof, pairs).toarray()
    own = np.zeros(len(ndof), bool)
    own[touched] = True
    rows = np.repeat(own, ndof)
    full[~rows] = False  # the untouched nodes' rows (and so columns) hold nothing
    full[:, ~rows] = False
    import scipy.sparse as sp

    ref = sp.csr_matrix(full)
    assert np.array_equal(pattern.indptr, ref.indptr)
    assert np.array_equal(pattern.indices, ref.indices)


def test_a_part_assembled_again_is_its_share_of_the_whole(write):
    """RepeatedAssembly: a flat and a curved shell strip, each of its own property, assembled
    apart with the whole model's grid normals, add up to the whole model's K and M, at
    every assembly of the same data (the positions kept from the first). With the flat
    part's own normals its drilling rotations along the common edge are not tied (that
    edge is curved in the whole), and its K differs."""
    from femcal.assembly import assemble
    from femcal.assembly.repeated import RepeatedAssembly
    from femcal.calibrate.parameters import subset
    from femcal.model.build import load_model

    lines = ["SOL 103", "CEND", "BEGIN BULK", "MAT1,1,210000.,,.3,7.85-9",
             "PSHELL,1,1,2.,1,,1", "PSHELL,2,1,3.,1,,1"]  # fmt: skip
    n_flat, n_arc, n_along, radius = 6, 6, 4, 200.0
    profile = [(-radius * (n_flat - i) / n_flat, 0.0) for i in range(n_flat)]
    profile += [(radius * np.sin(a), radius * (1.0 - np.cos(a)))
                for a in np.radians(np.linspace(0.0, 60.0, n_arc + 1))]  # fmt: skip
    for j in range(n_along + 1):
        for i, (x, z) in enumerate(profile):
            lines.append(f"GRID,{1 + i + 100 * j},,{float(x)!r},{50.0 * j!r},{float(z)!r}")
    eid = 1
    for j in range(n_along):
        for i in range(len(profile) - 1):
            g = 1 + i + 100 * j
            lines.append(f"CQUAD4,{eid},{1 + (i >= n_flat)},{g},{g + 1},{g + 101},{g + 100}")
            eid += 1
    lines.append("ENDDATA")
    model = load_model(write("\n".join(lines) + "\n", "curved.bdf"))
    whole = assemble(model)
    block = model.elements["CQUAD4"]
    K, M = 0.0, 0.0
    for pid in (1, 2):
        part = subset(model, {"CQUAD4": np.flatnonzero(block.pids == pid)})
        repeated = RepeatedAssembly(part, whole=model)
        Kd, Md = repeated.data(part)
        Kd2, _ = repeated.data(part)
        assert np.array_equal(Kd, Kd2)
        K = K + repeated.matrix(Kd)
        M = M + repeated.matrix(Md)
        if pid == 1:
            own = RepeatedAssembly(part).data(part)[0]
            assert np.abs(own - Kd).max() > 1e-6 * np.abs(Kd).max()
    scale = np.abs(whole.K.data).max()
    assert np.abs((K - whole.K).toarray()).max() < 1e-12 * scale
    assert np.abs((M - whole.M).toarray()).max() < 1e-12 * np.abs(whole.M.data).max()


def test_a_part_assembled_again_keeps_its_shape_not_its_sections(write):
    """The quadrilaterals' shape-only kernel data are kept between assemblies of the same
    elements (RepeatedAssembly): assemblies with other thicknesses, moduli and transverse
    shear (MID3 given, or shear-rigid) in any order equal a fresh assembly of each (to
    rounding: the kernels' products are BLAS's) and the whole model's matrices."""
    from femcal.assembly import assemble
    from femcal.assembly.repeated import RepeatedAssembly
    from femcal.model.build import load_model

    def deck(t1: float, t2: float, e: float, name: str):
        lines = ["SOL 103", "CEND", "BEGIN BULK", f"MAT1,1,{e!r},,.3,7.85-9",
                 f"PSHELL,1,1,{t1!r},1,,1", f"PSHELL,2,1,{t2!r},1"]  # fmt: skip
        rng = np.random.default_rng(3)
        for j in range(4):
            for i in range(6):
                z = 0.02 * i * i + rng.uniform(-0.3, 0.3)  # curved and warped
                lines.append(f"GRID,{1 + i + 10 * j},,{10.0 * i + rng.uniform(-1, 1)!r},"
                             f"{12.0 * j!r},{z!r}")  # fmt: skip
        for j in range(3):
            for i in range(5):
                g = 1 + i + 10 * j
                lines.append(f"CQUAD4,{1 + i + 10 * j},{1 + (i >= 3)},{g},{g + 1},{g + 11},"
                             f"{g + 10}")  # fmt: skip
        lines.append("ENDDATA")
        return load_model(write("\n".join(lines) + "\n", name))

    models = [deck(2.0, 3.0, 210000.0, "a.bdf"), deck(2.6, 1.5, 70000.0, "b.bdf"),
              deck(2.0, 3.0, 210000.0, "c.bdf")]  # fmt: skip
    repeated = RepeatedAssembly(models[0])
    for k, model in enumerate(models):
        Kd, Md = repeated.data(model)
        fresh_K, fresh_M = RepeatedAssembly(model).data(model)
        assert np.abs(Kd - fresh_K).max() <= 1e-13 * np.abs(fresh_K).max(), k
        assert np.abs(Md - fresh_M).max() <= 1e-13 * np.abs(fresh_M).max(), k
        whole = assemble(model)
        assert np.abs((repeated.matrix(Kd) - whole.K).toarray()).max() < (
            1e-12 * np.abs(whole.K.data).max())
    assert repeated._kept  # the shape was kept, and served the later assemblies
