"""The collapse loop's heap (`_heap`) and its quadric sums (`_decimate._summed`)."""

from __future__ import annotations

import heapq

import numpy as np
import pytest

from pointatlas.simplify._decimate import _summed
from pointatlas.simplify._heap import heap_grown, heap_pop, heap_push, heapify


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_pops_come_in_the_order_of_heapq_on_cost_then_key(seed):
    rng = np.random.default_rng(seed)
    # few distinct costs and keys: many ties on the cost, some on both
    first = 300
    cost = np.empty(4)
    key = np.empty(4, dtype=np.int64)
    data = np.empty(4, dtype=np.int64)
    cost, key, data = heap_grown(cost, key, data, 0, first)
    cost[:first] = rng.integers(0, 20, first) / 4.0
    key[:first] = rng.integers(0, 50, first)
    data[:first] = np.arange(first)
    heapify(cost, key, data, first)
    ref = [(cost[i], key[i]) for i in range(first)]
    heapq.heapify(ref)
    n, got, want = first, [], []
    for step in range(2000):
        if rng.random() < 0.45 and n > 0:
            c, k, d = heap_pop(cost, key, data, n)
            n -= 1
            got.append((c, k))
            want.append(heapq.heappop(ref))
        else:
            cost, key, data = heap_grown(cost, key, data, n, 1)
            c, k = float(rng.integers(0, 20)) / 4.0, int(rng.integers(0, 50))
            heap_push(cost, key, data, n, c, k, first + step)
            heapq.heappush(ref, (c, k))
            n += 1
    while n > 0:
        got.append(heap_pop(cost, key, data, n)[:2])
        want.append(heapq.heappop(ref))
        n -= 1
    assert [(float(c), int(k)) for c, k in got] == want
    assert cost.shape[0] >= first  # grown from 4


def test_an_entry_keeps_its_data_through_the_heap():
    cost, key, data = np.empty(64), np.empty(64, dtype=np.int64), np.empty(64, dtype=np.int64)
    rng = np.random.default_rng(3)
    c = rng.random(50)
    for i in range(50):
        heap_push(cost, key, data, i, c[i], i, 1000 + i)
    out = [heap_pop(cost, key, data, n) for n in range(50, 0, -1)]
    assert [int(d) - 1000 for _, _, d in out] == np.argsort(c, kind="stable").tolist()


def test_quadric_sums_are_np_add_at_bit_for_bit():
    rng = np.random.default_rng(4)
    n = 40
    at = [rng.integers(0, n, 500), rng.integers(0, n, 300)]
    terms = [rng.normal(size=(500, 16)) * 1e3, rng.normal(size=(300, 16)) * 1e-3]
    ref = np.zeros((n, 16))
    for idx, w in zip(at, terms, strict=True):
        np.add.at(ref, idx, w)
    assert np.array_equal(_summed(at, terms, n), ref)
    flat = np.zeros(n)
    for idx, w in zip(at, terms, strict=True):
        np.add.at(flat, idx, w[:, 0])
    assert np.array_equal(_summed(at, [w[:, 0] for w in terms], n), flat)
