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
    first = datasets.files_of("fluxpart_csat3_toa5")[0]
    got = hashlib.sha256(b"x" * first.size).hexdigest()
    with pytest.raises(InputError) as err:
        datasets.get_record("fluxpart_csat3_toa5")
    assert str(err.value) == (f"{tmp_path / first.path}: file of record 'fluxpart_csat3_toa5': sha256 {got}, "
                              f"expected {first.sha256} (registry of dronewind.datasets); replace the file "
                              "(python -m dronewind.datasets fetch fluxpart_csat3_toa5)")


def test_manifest_data_root_registry(monkeypatch, tmp_path):
    monkeypatch.setenv(datasets.ENV_VAR, str(tmp_path))
    manifest = tmp_path / "c.yaml"
    assert _data_root(manifest, {"data_root": "registry"}) == tmp_path.resolve()
    assert _data_root(manifest, {"data_root": "./registry"}) == (tmp_path / "registry").resolve()


def test_real_record_fixture(real_record):
    """Runs where the data folder holds the record, skips with the fetch command elsewhere."""
    folder = real_record("px4_ulog")
    assert (folder / "sample_log_small.ulg").is_file()


def test_licence_and_notes_files_are_optional(monkeypatch, tmp_path, real_record):
    """A record counts as present with its data files alone; a licence file present is checked too."""
    import shutil

    source = real_record("px4_ulog")
    monkeypatch.setenv(datasets.ENV_VAR, str(tmp_path))
    (tmp_path / "px4_ulog").mkdir()
    for f in datasets.files_of("px4_ulog"):
        if f.needed:
            shutil.copy(source / f.path.split("/", 1)[1], tmp_path / f.path)
    assert datasets.is_present("px4_ulog") and datasets.get_record("px4_ulog") == tmp_path / "px4_ulog"
    (tmp_path / "px4_ulog" / "LICENSE.md").write_text("not the licence")
    with pytest.raises(InputError, match="LICENSE.md: file of record .px4_ulog.: size 15 bytes, expected 1492"):
        datasets.get_record("px4_ulog")
