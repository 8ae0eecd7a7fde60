"""Steps reused inside a forward flight's runs (dronewind.core.reuse): exact, scoped, and counted."""

import numpy as np
import pytest

from dronewind.core.filtering import despike_moving_mad
from dronewind.core.reuse import StepStore, reused, reusing, same_bits
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
    with reusing(cache.steps):
        first = despike_moving_mad(x, 20.0, 10.0, 7.0)
        first[:] = True  # a caller's change must not reach the stored flags
        second = despike_moving_mad(x.copy(), 20.0, 10.0, 7.0)
        other_window = despike_moving_mad(x, 20.0, 5.0, 7.0)
    np.testing.assert_array_equal(second, plain)
    assert cache.steps.hits == 1 and cache.steps.misses == 2
    np.testing.assert_array_equal(other_window, despike_moving_mad(x, 20.0, 5.0, 7.0))


def test_inputs_are_compared_bit_for_bit_and_kept_as_copies():
    store = StepStore()
    make, calls = _counting("r")
    x = np.array([1.0, np.nan, -0.0])
    with reusing(store):
        reused("step", {"x": x}, "", make)
        reused("step", {"x": np.array([1.0, np.nan, -0.0])}, "", make)  # NaN equals NaN bit for bit
        reused("step", {"x": np.array([1.0, np.nan, 0.0])}, "", make)  # +0 is not -0
        reused("step", {"x": x.astype(np.float32)}, "", make)  # another dtype
        x[0] = 2.0  # the caller changes its array: the stored input does not change
        reused("step", {"x": np.array([1.0, np.nan, -0.0])}, "", make)
        reused("step", {"x": x, "y": x}, "", make)  # other names
    assert len(calls) == 4 and (store.hits, store.misses) == (2, 4)


@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.int8, np.bool_, np.complex128, np.int16])
def test_same_bits_of_every_item_size(dtype):
    a = (np.arange(12) % 3).astype(dtype).reshape(3, 4)
    assert same_bits(a, a.copy()) and same_bits(a[:, ::2], a[:, ::2].copy())
    b = a.copy()
    b[0, 0] = 1  # a[0, 0] is 0 (False)
    assert not same_bits(a, b) and not same_bits(a, a.reshape(4, 3))
    with pytest.raises(TypeError, match="object"):
        same_bits(np.array([None]), np.array([None]))


@pytest.mark.parametrize("shape", [(1000,), (1000, 3), (300, 2, 2)])
@pytest.mark.parametrize("dtype", [np.float64, np.float32, np.int8, np.complex128])
def test_same_bits_of_long_arrays_wherever_they_differ(shape, dtype):
    """Long arrays are compared on their leading rows first: a difference anywhere still counts."""
    a = np.random.default_rng(1).normal(size=shape).astype(dtype)
    assert same_bits(a, a.copy()) and same_bits(a[::2], a[::2].copy()) and same_bits(a[:, ...], a.copy())
    for row in (0, 63, 64, shape[0] // 2, shape[0] - 1):
        b = a.copy()
        b[row] = b[row] + 1
        assert not same_bits(a, b) and not same_bits(b, a)
    plus, minus = np.zeros(1000), np.zeros(1000)
    minus[-1] = -0.0  # equal numbers, other bits, at the very end
    assert not same_bits(plus, minus)


def test_products_are_found_by_equal_records_and_not_by_other_ones():
    """ForwardCache finds a product by the same record objects or bit-identical columns; one
    changed value, another source or another settings text is a miss; file paths match only
    as the same object."""
    from pathlib import Path

    from dronewind.core.raw import RawRecord
    from dronewind.diagnose.forward import same_records

    cols = {"t": np.arange(5, dtype=np.int64), "x": np.array([0.0, np.nan, 1.0, 2.0, 3.0])}
    rec = RawRecord("a.csv", cols)
    twin = RawRecord("a.csv", {k: v.copy() for k, v in cols.items()})
    changed = RawRecord("a.csv", {"t": cols["t"], "x": np.array([0.0, np.nan, 1.0, 2.0, 3.5])})
    moved = RawRecord("b.csv", cols)
    objects = RawRecord("a.csv", {**cols, "s": np.array(["p", "q", "r", "s", "t"], dtype=object)})
    assert same_records([rec], [twin]) and not same_records([rec, Path("f.csv")], [twin, Path("f.csv")])
    assert not same_records([rec], [changed]) and not same_records([rec], [moved])
    assert same_records([objects], [RawRecord("a.csv", {**cols, "s": np.array(list("pqrst"), dtype=object)})])
    cache = ForwardCache()
    make, calls = _counting("L1")
    path = Path("f.csv")
    for records in ([rec], [twin], [changed], [path], [path]):
        cache.get("l1", records, make)
    cache.get("l1", [rec], make, settings="other")
    assert len(calls) == 4 and (cache.hits, cache.misses) == (2, 4)


def test_results_are_read_only_inside_a_block_and_out():
    """A result that may be handed out again cannot be changed by whoever gets it: its arrays,
    also inside tuples, dictionaries and dataclasses, are read-only with or without a store."""
    from dataclasses import dataclass

    @dataclass(frozen=True)
    class Pair:
        a: np.ndarray
        notes: list

    def make():
        return (np.zeros(3), {"b": np.ones(2)}, Pair(np.arange(4.0), ["x"]), 1.5)

    for store in (None, StepStore()):
        with reusing(store) if store is not None else _nothing():
            arr, mapping, pair, number = reused("step", {"x": np.zeros(1)}, "", make)
        for a in (arr, mapping["b"], pair.a):
            with pytest.raises(ValueError, match="read-only"):
                a[0] = 1.0
        assert number == 1.5 and pair.notes == ["x"]


def _nothing():
    import contextlib

    return contextlib.nullcontext()


def test_forward_products_are_read_only_and_windows_are_views_of_them():
    """A product stored in a flight's ForwardCache (an L1 dataset) is read-only for every later
    run: its variables' arrays, a data array's too, and views of them, such as the L2's window
    of an L1 (dronewind.payload.l2._kept: a slice where the kept samples are one run)."""
    import xarray as xr

    from dronewind.payload.l2 import _kept

    ds = xr.Dataset({"u": ("time", np.arange(6.0)), "flag": ("time", np.zeros(6, dtype=np.int8))},
                    coords={"time": np.arange(6)})
    cache = ForwardCache()
    stored = cache.get("l1", ["a"], lambda: ds)
    window = stored.isel(time=_kept(np.array([False, True, True, True, False, False])))
    assert isinstance(_kept(np.array([False, True, True, True, False, False])), slice)
    assert list(_kept(np.array([True, False, True, False, False, False]))) == [0, 2]
    for arr in (stored["u"].values, stored["flag"].values, window["u"].values):
        with pytest.raises(ValueError, match="read-only"):
            arr[0] = 1
    da = xr.DataArray(np.ones(3), coords={"x": ("x", np.arange(3.0))}, dims="x")
    from dronewind.core.reuse import read_only

    with pytest.raises(ValueError, match="read-only"):
        read_only(da).values[0] = 2.0


def test_read_only_leaves_a_lazily_loaded_dataset_unread(tmp_path):
    """read_only marks the arrays a dataset holds; a variable still on disk is not read for it."""
    import xarray as xr

    from dronewind.core.reuse import read_only

    path = tmp_path / "lazy.nc"
    xr.Dataset({"u": ("time", np.arange(5.0))}).to_netcdf(path)
    with xr.open_dataset(path) as ds:
        read_only(ds)
        assert not ds["u"].variable._in_memory
        loaded = ds.load()
        read_only(loaded)
        with pytest.raises(ValueError, match="read-only"):
            loaded["u"].values[0] = 1.0
