"""The event queue: an indexed binary min-heap of the particles keyed by the time of
each one's next event (Lubachevsky 1991, ref. 37: one pending event per particle).

``heap[k]`` is the particle at slot ``k`` (the earliest at slot 0), ``pos[i]`` the slot
of particle ``i``, ``key[i]`` its event time. A changed key moves its particle up or down
in ``O(log N)``; ties keep the order the moves leave, so a run is the same every time.
"""
from __future__ import annotations

import numpy as np

from pysim.jit import inline_njit, njit


@inline_njit
def sift_up(heap, pos, key, k):
    """Move the particle at slot ``k`` up while its key is below its parent's."""
    i = heap[k]
    t = key[i]
    while k > 0:
        up = (k - 1) >> 1
        p = heap[up]
        if key[p] <= t:
            break
        heap[k] = p
        pos[p] = k
        k = up
    heap[k] = i
    pos[i] = k


@inline_njit
def sift_down(heap, pos, key, k):
    """Move the particle at slot ``k`` down while a child has a smaller key."""
    n = heap.shape[0]
    i = heap[k]
    t = key[i]
    while True:
        c = 2 * k + 1
        if c >= n:
            break
        if c + 1 < n and key[heap[c + 1]] < key[heap[c]]:
            c += 1
        q = heap[c]
        if key[q] >= t:
            break
        heap[k] = q
        pos[q] = k
        k = c
    heap[k] = i
    pos[i] = k


@inline_njit
def update(heap, pos, key, i):
    """Restore the heap after ``key[i]`` changed."""
    k = pos[i]
    if k > 0 and key[heap[(k - 1) >> 1]] > key[i]:
        sift_up(heap, pos, key, k)
    else:
        sift_down(heap, pos, key, k)


@njit
def build(heap, pos, key):
    """Fill ``heap``/``pos`` with every particle ``0..N-1`` ordered by ``key``."""
    n = heap.shape[0]
    for i in range(n):
        heap[i] = i
        pos[i] = i
    for k in range(n // 2 - 1, -1, -1):
        sift_down(heap, pos, key, k)


def empty(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``(heap, pos)`` arrays for ``n`` particles."""
    return np.zeros(n, np.int64), np.zeros(n, np.int64)
