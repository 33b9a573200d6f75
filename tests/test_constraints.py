"""The a-set selection of rows and columns (femcal.assembly.constraints.select_symmetric)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp

from femcal.assembly.constraints import select_symmetric


@pytest.mark.parametrize("n", [1, 5, 50, 700])
def test_select_symmetric_equals_fancy_indexing(n):
    rng = np.random.default_rng(n)
    A = sp.random(n, n, density=0.3, random_state=rng, format="csr")
    A = (A + A.T).tocsr()
    subsets = [np.arange(n), np.flatnonzero(rng.random(n) < 0.6), np.zeros(0, np.int64),
               rng.permutation(n)[: max(1, n // 2)]]  # increasing, and not (scipy's path)
    for keep in subsets:
        got = select_symmetric(A, keep)
        got.check_format(full_check=True)
        np.testing.assert_array_equal(got.toarray(), A.toarray()[np.ix_(keep, keep)])


def test_zero_rows_with_and_without_stored_zeros():
    """A row is zero when it stores nothing or only zeros; a stored nonzero makes it not."""
    from femcal.assembly.constraints import _zero_rows

    rng = np.random.default_rng(3)
    A = sp.random(40, 40, density=0.05, random_state=rng, format="csr")
    A.data[:] = rng.standard_normal(A.nnz)  # every stored value nonzero
    expected = np.asarray(abs(A).sum(axis=1)).ravel() == 0
    assert expected.any() and not expected.all()
    np.testing.assert_array_equal(_zero_rows(A), expected)
    # the same values with zeros stored in rows that hold nothing else, and beside nonzeros
    coo = A.tocoo()
    empty = np.flatnonzero(expected)[:3]
    full = np.flatnonzero(~expected)[:3]
    rows = np.r_[coo.row, empty, full]
    cols = np.r_[coo.col, empty, (full + 1) % 40]
    B = sp.csr_matrix((np.r_[coo.data, np.zeros(6)], (rows, cols)), shape=A.shape)
    B.sum_duplicates()
    assert B.nnz > A.nnz and np.count_nonzero(B.data) < B.nnz
    np.testing.assert_array_equal(_zero_rows(B), expected)


def test_zero_rows_of_duplicates_that_cancel():
    """Duplicates that cancel (+1 and -1 at one place) leave a zero row, as the sum of the
    magnitudes of the summed entries says; a row count would not."""
    from femcal.assembly.constraints import _zero_rows

    A = sp.csr_matrix((np.array([1.0, -1.0, 2.0]), np.array([1, 1, 0]), np.array([0, 2, 3, 3])),
                      shape=(3, 3))  # fmt: skip
    assert not A.has_canonical_format
    np.testing.assert_array_equal(_zero_rows(A), [True, False, True])
