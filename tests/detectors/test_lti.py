import numpy as np
import pytest

from analyzer.detectors.lti import LiftedSystem, simulate_reference


@pytest.mark.parametrize("T", [1, 7, 32])
@pytest.mark.parametrize("N", [1, 31, 500])
def test_lifted_equals_recursion(T, N):
    rng = np.random.default_rng(T * 1000 + N)
    n, r, q = 12, 3, 4
    F = rng.normal(size=(n, n))
    F *= 0.9 / np.max(np.abs(np.linalg.eigvals(F)))
    G, H, J = rng.normal(size=(n, r)), rng.normal(size=(q, n)), rng.normal(size=(q, r))
    u = rng.normal(size=(N, r))
    y, _ = LiftedSystem.build(F, G, H, J, T).run(u, chunk=64)
    np.testing.assert_allclose(y, simulate_reference(F, G, H, J, u), rtol=1e-9, atol=1e-9)


def test_state_carries_across_calls():
    rng = np.random.default_rng(5)
    n, r, q = 6, 2, 2
    F = np.diag(rng.uniform(-0.9, 0.9, n))
    G, H, J = rng.normal(size=(n, r)), rng.normal(size=(q, n)), np.zeros((q, r))
    u = rng.normal(size=(300, r))
    sys_ = LiftedSystem.build(F, G, H, J, 16)
    whole, _ = sys_.run(u)
    first, x = sys_.run(u[:137])
    second, _ = sys_.run(u[137:], x0=x)
    np.testing.assert_allclose(np.vstack([first, second]), whole, atol=1e-12)


def _stable_systems(rng, count, n, r, q, radius):
    """``count`` random systems ``(F, G, H, J)`` with ``n`` states, ``r`` inputs and ``q``
    outputs, ``F`` scaled to spectral radius ``radius``."""
    systems = []
    for _ in range(count):
        F = rng.normal(size=(n, n))
        F *= radius / np.max(np.abs(np.linalg.eigvals(F)))
        systems.append(
            (F, rng.normal(size=(n, r)), rng.normal(size=(q, n)), rng.normal(size=(q, r)))
        )
    return systems


def test_a_bank_too_large_for_memory_runs_in_lifted_form(monkeypatch):
    """Above MAX_BANK_BYTES the impulse-response bank is not built (its size grows as
    channels^3 x taps); the lifted form gives the same outputs."""
    import analyzer.detectors.lti as lti

    rng = np.random.default_rng(1)
    systems = _stable_systems(rng, 3, n=6, r=4, q=3, radius=0.8)
    u = rng.normal(size=(3000, 4))
    fir = lti.system_bank(systems)
    assert isinstance(fir, lti.ImpulseResponseBank)
    monkeypatch.setattr(lti, "MAX_BANK_BYTES", 1000)
    lifted = lti.system_bank(systems)
    assert isinstance(lifted, lti.LiftedBank)
    a = np.concatenate([y for _, y in fir.run(u)], axis=2)
    b = np.concatenate([y for _, y in lifted.run(u)], axis=2)
    np.testing.assert_allclose(a, b, atol=1e-10)


def test_subset_of_a_bank_runs_its_systems_and_is_kept(monkeypatch):
    """A subset of the bank's systems gives those systems' outputs of the whole bank (to
    rounding); asked for again it is the same object, and only the last SUBSETS_KEPT are
    kept. A pickled bank (a cluster's task) runs the same."""
    import pickle

    import analyzer.detectors.lti as lti

    rng = np.random.default_rng(3)
    systems = _stable_systems(rng, 6, n=5, r=3, q=2, radius=0.7)
    bank = lti.system_bank(systems)
    assert isinstance(bank, lti.ImpulseResponseBank)
    u = rng.normal(size=(2500, 3))
    whole = np.concatenate([y for _, y in bank.run(u)], axis=2)
    for pick in ([4], [0, 5], [2]):
        one = bank.subset(pick)
        got = np.concatenate([y for _, y in one.run(u)], axis=2)
        np.testing.assert_allclose(got, whole[pick], rtol=1e-12, atol=1e-12)
        assert bank.subset(pick) is one
    monkeypatch.setattr(lti, "SUBSETS_KEPT", 2)
    first = bank.subset([1])
    bank.subset([3])
    bank.subset([4])  # [1] is the oldest: dropped
    assert len(bank.subsets) == 2 and bank.subset([1]) is not first
    copy = pickle.loads(pickle.dumps(bank))
    np.testing.assert_array_equal(
        np.concatenate([y for _, y in copy.subset([4]).run(u)], axis=2),
        np.concatenate([y for _, y in bank.subset([4]).run(u)], axis=2),
    )


@pytest.mark.parametrize("shares_memory", [True, False])
def test_time_blocks_cover_the_span_and_are_bounded_on_a_cluster(shares_memory, two_thread_pool):
    """Threads: about two blocks per worker whatever the length; a cluster (no shared
    memory): blocks of at most CLUSTER_BLOCK_VALUES values of the given width (or one
    MIN_TIME_BLOCK of warm-ups), so a long archive goes out in many bounded pieces."""
    from analyzer.detectors.base import RunContext
    from analyzer.detectors.lti import CLUSTER_BLOCK_VALUES, MIN_TIME_BLOCK, time_blocks

    ctx = RunContext(jobs=2, executor=two_thread_pool(shares_memory))
    start, stop, warmup, width = 1000, 9_000_000, 300, 16
    spans = time_blocks(start, stop, warmup, ctx, width)
    assert spans[0][0] == start and spans[-1][1] == stop
    assert all(b == a2 for (_, b, _), (a2, _, _) in zip(spans[:-1], spans[1:], strict=True))
    assert all(w == min(a, warmup) for a, _, w in spans)
    longest = max(b - a for a, b, _ in spans)
    if shares_memory:
        assert len(spans) == 4
    else:
        assert longest <= CLUSTER_BLOCK_VALUES // width
        assert len(spans) == -(-(stop - start) // longest) > 4
        wide = time_blocks(start, stop, warmup, ctx, 10**6)  # one warm-up block minimum
        assert max(b - a for a, b, _ in wide) == MIN_TIME_BLOCK * warmup
    assert time_blocks(start, stop, warmup, RunContext(), width) == [(start, stop, warmup)]
