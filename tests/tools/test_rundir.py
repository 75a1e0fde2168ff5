"""Output directories written whole (attitude_tools.output.rundir), shared by attitude-offline,
attitude-run and attitude-report."""

import pytest

from attitude_tools.output.rundir import check_replaceable, publish, stage


def test_only_missing_empty_or_previous_output_is_replaceable(tmp_path):
    assert check_replaceable(tmp_path / "new", ("summary.json",), "run") == tmp_path / "new"
    (tmp_path / "empty").mkdir()
    check_replaceable(tmp_path / "empty", ("summary.json",), "run")
    previous = tmp_path / "previous"
    previous.mkdir()
    (previous / "summary.json").write_text("{}")
    check_replaceable(previous, ("summary.json",), "run")
    foreign = tmp_path / "foreign"
    foreign.mkdir()
    (foreign / "notes.txt").write_text("mine")
    with pytest.raises(FileExistsError, match="not a previous run"):
        check_replaceable(foreign, ("summary.json",), "run")
    (tmp_path / "file").write_text("x")
    with pytest.raises(FileExistsError, match="not a previous report"):
        check_replaceable(tmp_path / "file", ("report.html",), "report")


def test_publish_replaces_the_previous_directory_whole(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old")
    tmp = stage(out, ".tmp-x-")
    assert tmp.parent == tmp_path and tmp.name.startswith(".tmp-x-")
    (tmp / "new.txt").write_text("new")
    publish(tmp, out)
    assert sorted(p.name for p in out.iterdir()) == ["new.txt"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # nothing left beside it


def test_a_failed_publish_puts_the_previous_directory_back(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    (out / "old.txt").write_text("old")
    with pytest.raises(FileNotFoundError):
        publish(tmp_path / "vanished", out)
    assert (out / "old.txt").read_text() == "old"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]
