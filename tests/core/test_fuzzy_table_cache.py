"""The disk cache of the FIS lookup tables (attitude_core.fsw.guidance.fuzzy.table_cache): a
table read back is the built one bit for bit, a bad entry is rebuilt, the key follows
the definition, and a cache that cannot be written never fails a planner."""

from __future__ import annotations

import copy

import numpy as np
import pytest

from attitude_core.fsw.guidance.fuzzy import (
    FisTable,
    MamdaniFis,
    load_fis,
    lookup_table,
    table_cache,
)
from attitude_core.fsw.guidance.fuzzy import table as table_module

NAMES = ("fis_attractive.yaml", "fis_repulsive.yaml")  # 1 and 2 inputs


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """An empty cache directory of this test's own; the per-process cache cleared."""
    where = tmp_path / "fis_tables"
    monkeypatch.setenv(table_cache.ENV, str(where))
    _forget()
    yield where
    _forget()


def _forget():
    """Clear the per-process caches (by definition and by FIS object)."""
    table_module._table_from_json.cache_clear()
    table_module._table_of.cache_clear()


def _no_build(monkeypatch):
    def refuse(*args, **kwargs):
        raise AssertionError("the table was built, not read from the cache")

    monkeypatch.setattr(FisTable, "build", staticmethod(refuse))


def _inputs(table, n=2000, seed=3):
    rng = np.random.default_rng(seed)
    cols = [rng.uniform(lo - 0.1, hi + 0.1, n) for lo, hi in table.universes]
    return list(zip(*cols, strict=True))


@pytest.mark.parametrize("name", NAMES)
def test_a_table_read_back_is_the_built_one_bit_for_bit(cache, monkeypatch, name):
    fis = load_fis(name)
    built = lookup_table(fis)  # built and stored
    assert len(list(cache.glob("*.npz"))) == 1
    _forget()
    _no_build(monkeypatch)
    read = lookup_table(fis)  # a new process would do this: read, not build
    assert read is not built
    for a, b in zip(read.axes, built.axes, strict=True):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(read.values, built.values)
    assert read.max_abs_error_estimate == built.max_abs_error_estimate
    assert read.tol == built.tol and read.universes == built.universes
    assert (read.name, read.input_names, read.output_name) == (
        built.name,
        built.input_names,
        built.output_name,
    )
    for x in _inputs(built):
        assert read(*x) == built(*x)  # exactly, in and out of the universe
    exact = fis.evaluate_grid  # and it is still the FIS: within the build tolerance
    grid = [np.linspace(lo, hi, 41) for lo, hi in fis.input_universes]
    mesh = np.meshgrid(*grid, indexing="ij")
    want = exact(*mesh)
    got = np.vectorize(read)(*mesh)
    assert np.max(np.abs(got - want)) <= 2.0 * read.tol


@pytest.mark.parametrize("damage", ["truncated", "garbage", "wrong_shape", "not_increasing"])
def test_a_bad_entry_is_rebuilt_and_replaced(cache, damage):
    fis = load_fis("fis_repulsive.yaml")
    good = lookup_table(fis)
    (entry,) = cache.glob("*.npz")
    if damage == "truncated":
        entry.write_bytes(entry.read_bytes()[:1000])
    elif damage == "garbage":
        entry.write_bytes(b"not an npz file")
    else:
        axes, values = list(good.axes), good.values
        if damage == "wrong_shape":
            values = values[:-1]
        else:
            axes[0] = axes[0][::-1].copy()
        np.savez(
            entry, values=values, error=good.max_abs_error_estimate, tol=good.tol,
            axis0=axes[0], axis1=axes[1],
        )  # fmt: skip
    _forget()
    again = lookup_table(fis)
    np.testing.assert_array_equal(again.values, good.values)
    _forget()
    assert table_cache.load(entry.stem, 2) is not None  # the rebuilt entry was written
    for x in _inputs(good, 200):
        assert again(*x) == good(*x)


def test_the_key_follows_the_definition_and_the_build(cache):
    fis = load_fis("fis_attractive.yaml")
    edited = copy.deepcopy(fis.spec)
    first = next(iter(edited["output"]["terms"].values()))
    first["params"] = [p * 0.999 for p in first["params"]]
    import json

    key = table_cache.cache_key(json.dumps(fis.spec, sort_keys=True), "table()")
    assert key == table_cache.cache_key(json.dumps(fis.spec, sort_keys=True), "table()")
    assert key != table_cache.cache_key(json.dumps(edited, sort_keys=True), "table()")
    assert key != table_cache.cache_key(json.dumps(fis.spec, sort_keys=True), "table(tol=0.01)")
    lookup_table(fis)
    lookup_table(MamdaniFis(edited, label="edited"))
    assert len(list(cache.glob("*.npz"))) == 2  # an edited FIS gets an entry of its own


def test_off_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.setenv(table_cache.ENV, "off")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    _forget()
    try:
        assert table_cache.cache_dir() is None
        lookup_table(load_fis("fis_attractive.yaml"))
        assert list(tmp_path.rglob("*")) == []
    finally:
        _forget()


def test_the_default_location_follows_xdg(tmp_path, monkeypatch):
    monkeypatch.delenv(table_cache.ENV, raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert table_cache.cache_dir() == tmp_path / "attitude_stack" / "fis_tables"


def test_an_unwritable_cache_is_skipped(tmp_path, monkeypatch):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a directory")
    monkeypatch.setenv(table_cache.ENV, str(blocker / "fis_tables"))  # mkdir fails
    _forget()
    try:
        fis = load_fis("fis_repulsive.yaml")
        table = lookup_table(fis)
        reference = FisTable.build(fis)
        np.testing.assert_array_equal(table.values, reference.values)
    finally:
        _forget()
