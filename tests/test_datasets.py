"""The record registry (dronewind.datasets) and ``data_root: registry`` in manifests."""

from __future__ import annotations

import hashlib

import pytest

from dronewind import datasets
from dronewind.errors import InputError
from dronewind.manifest import _data_root


def test_registry_covers_every_record_with_licence_and_source():
    files = datasets.registry()
    assert {p.split("/", 1)[0] for p in files} == set(datasets.RECORDS)
    for rec in datasets.RECORDS.values():
        names = {f.path.rsplit("/", 1)[1] for f in datasets.files_of(rec.name)}
        assert rec.licence_file in names and rec.licence and rec.source
    assert all(len(f.sha256) == 64 and f.size > 0 for f in files.values())


def test_data_folder_from_environment(monkeypatch, tmp_path):
    monkeypatch.setenv(datasets.ENV_VAR, str(tmp_path))
    assert datasets.data_dir() == tmp_path.resolve()
    assert not datasets.is_present("px4_ulog")
    with pytest.raises(FileNotFoundError, match="python -m dronewind.datasets fetch px4_ulog"):
        datasets.get_record("px4_ulog")
    with pytest.raises(InputError, match="no such record; expected one of"):
        datasets.get_record("nope")


def test_checksum_mismatch_names_file_expected_and_found(monkeypatch, tmp_path):
    """A file of the registered size but other bytes is refused with both hashes."""
    monkeypatch.setenv(datasets.ENV_VAR, str(tmp_path))
    for f in datasets.files_of("fluxpart_csat3_toa5"):
        path = tmp_path / f.path
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(b"x" * f.size)
    bad = hashlib.sha256(b"x" * datasets.registry()["fluxpart_csat3_toa5/LICENSE"].size).hexdigest()
    with pytest.raises(InputError) as err:
        datasets.get_record("fluxpart_csat3_toa5")
    assert "fluxpart_csat3_toa5/" in str(err.value) and "expected" in str(err.value)
    if "LICENSE" in str(err.value):
        assert bad in str(err.value)


def test_manifest_data_root_registry(monkeypatch, tmp_path):
    monkeypatch.setenv(datasets.ENV_VAR, str(tmp_path))
    manifest = tmp_path / "c.yaml"
    assert _data_root(manifest, {"data_root": "registry"}) == tmp_path.resolve()
    assert _data_root(manifest, {"data_root": "./registry"}) == (tmp_path / "registry").resolve()


def test_real_record_fixture(real_record):
    """Runs where the data folder holds the record, skips with the fetch command elsewhere."""
    folder = real_record("px4_ulog")
    assert (folder / "sample_log_small.ulg").is_file()
