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
