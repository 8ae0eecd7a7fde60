"""Steps reused inside a forward flight's runs (dronewind.core.reuse): exact, scoped, and counted."""

import numpy as np

from dronewind.core.filtering import despike_moving_mad
from dronewind.core.reuse import reused, reusing
from dronewind.diagnose.forward import ForwardCache


def _counting(value):
    calls = []

    def make():
        calls.append(1)
        return value

    return make, calls


def test_outside_a_block_every_call_computes():
    make, calls = _counting(3.0)
    x = np.arange(5.0)
    assert reused("step", {"x": x}, "", make) == 3.0
    assert reused("step", {"x": x}, "", make) == 3.0
    assert len(calls) == 2


def test_inside_a_block_equal_inputs_are_looked_up_and_others_computed():
    cache = ForwardCache()
    assert cache.steps is not None
    make, calls = _counting("r")
    x = np.arange(5.0)
    with reusing(cache.steps):
        reused("step", {"x": x}, "fs=1", make)
        reused("step", {"x": x.copy()}, "fs=1", make)  # equal content, another array: found
        reused("step", {"x": x + 1e-12}, "fs=1", make)  # one bit differs: computed
        reused("step", {"x": x}, "fs=2", make)  # other settings: computed
        reused("other step", {"x": x}, "fs=1", make)  # another step: computed
    assert len(calls) == 4
    assert (cache.steps.hits, cache.steps.misses) == (1, 4)
    reused("step", {"x": x}, "fs=1", make)  # the block is over: computed again
    assert len(calls) == 5


def test_steps_are_stored_only_until_the_forward_cache_is_frozen():
    cache = ForwardCache()
    assert cache.steps is not None and cache.steps.steps is None
    make, calls = _counting(1)
    with reusing(cache.steps):
        cache.freeze()
        reused("step", {"x": np.zeros(3)}, "", make)
        reused("step", {"x": np.zeros(3)}, "", make)
    assert len(calls) == 2 and cache.steps.frozen


def test_despiking_gives_the_same_flags_with_and_without_reuse_and_copies():
    rng = np.random.default_rng(5)
    x = rng.standard_normal(2000)
    x[[100, 900, 1500]] += 25.0
    x[50:60] = np.nan
    plain = despike_moving_mad(x, 20.0, 10.0, 7.0)
    assert set(np.flatnonzero(plain)) == {100, 900, 1500}
    cache = ForwardCache()
    assert cache.steps is not None
    with reusing(cache.steps):
        first = despike_moving_mad(x, 20.0, 10.0, 7.0)
        first[:] = True  # a caller's change must not reach the stored flags
        second = despike_moving_mad(x.copy(), 20.0, 10.0, 7.0)
        other_window = despike_moving_mad(x, 20.0, 5.0, 7.0)
    np.testing.assert_array_equal(second, plain)
    assert cache.steps.hits == 1 and cache.steps.misses == 2
    np.testing.assert_array_equal(other_window, despike_moving_mad(x, 20.0, 5.0, 7.0))
