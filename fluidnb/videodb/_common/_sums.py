"""numpy's summation order in compiled code: the same sums, to the bit.

numpy adds the values of a reduction along a contiguous axis by pairwise summation
(``pairwise_sum`` in numpy's ``loops_utils.h.src``): blocks of up to 128 values in
eight running sums combined as a tree, longer ranges split in halves (the first a
multiple of 8) whose sums are added, and that added to the reduction's start, 0.
Kernels that must give numpy's bits (the MRF's energies, the stored textureness) sum
with :func:`_pairwise_sum`; in the array's own type, float32 or float64.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = []

__all__: list[str] = []


@njit(cache=True, nogil=True)
def _block_sum(a, lo, n):
    """The sum of one block of up to 128 values as numpy adds it: eight running sums."""
    if n < 8:
        total = a.dtype.type(0)  # numpy starts at -0.0: the same once 0 is added
        for i in range(lo, lo + n):
            total += a[i]
        return total
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    whole = n - n % 8
    for i in range(lo + 8, lo + whole, 8):
        r0 += a[i]
        r1 += a[i + 1]
        r2 += a[i + 2]
        r3 += a[i + 3]
        r4 += a[i + 4]
        r5 += a[i + 5]
        r6 += a[i + 6]
        r7 += a[i + 7]
    total = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    for i in range(lo + whole, lo + n):
        total += a[i]
    return total


@njit(cache=True, nogil=True)
def _pairwise_sum(a):
    """``a.sum()`` of a contiguous float32 or float64 array, to the bit (numpy's order).

    numpy sums blocks of up to 128 values (:func:`_block_sum`) and halves longer
    ranges (the first half a multiple of 8), adding the two halves' sums; here with a
    stack of ranges instead of recursion (numba's cache cannot load a function that
    calls a recursive one: it crashes). In ``a``'s type throughout.
    """
    zero = a.dtype.type(0)
    n = len(a)
    if n <= 128:
        return zero + _block_sum(a, 0, n)  # numpy adds to its start value, 0
    # Tasks: (lo, n) to sum, or (-1, 0) to add the two last sums.
    task_lo = np.empty(192, np.int64)
    task_n = np.empty(192, np.int64)
    sums = np.empty(96, a.dtype)
    task_lo[0], task_n[0] = 0, n
    tasks, found = 1, 0
    while tasks:
        tasks -= 1
        lo, m = task_lo[tasks], task_n[tasks]
        if lo < 0:
            found -= 1
            sums[found - 1] += sums[found]  # (left + right): addition commutes exactly
        elif m <= 128:
            sums[found] = _block_sum(a, lo, m)
            found += 1
        else:
            half = m // 2
            half -= half % 8
            task_lo[tasks], task_n[tasks] = -1, 0
            task_lo[tasks + 1], task_n[tasks + 1] = lo + half, m - half
            task_lo[tasks + 2], task_n[tasks + 2] = lo, half
            tasks += 3
    return zero + sums[0]
