"""Sparse assembly: the pattern and the scatter agree with a dense reference assembly."""

from __future__ import annotations

import numpy as np

from femcal.assembly import Assembler, Pattern


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

    from femcal.structure import _compact

    A = sp.csr_matrix(np.array([[1.0, 0, 2], [0, 0, 0], [0, 0, 3.0]]))
    A.data[0] = 0.0  # a stored zero in row 0; row 1 has no entries at all
    B = _compact(A)
    assert B.nnz == 2 and np.array_equal(B.toarray(), A.toarray())
    R = sp.random(60, 60, density=0.2, format="csr", random_state=3)
    R.data[::4] = 0.0
    C = _compact(R)
    assert C.nnz == int((R.data != 0).sum()) and abs(C - R).max() == 0.0
