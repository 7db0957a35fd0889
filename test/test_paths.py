"""Tests of rigid_body_sim.paths: the config directory is found in each kind of installation."""

from __future__ import annotations

from pathlib import Path

import pytest

from rigid_body_sim import paths

REPO_ROOT = Path(__file__).resolve().parent.parent


def _fake_prefix(root: Path) -> Path:
    """Lay out ``<root>/share/...`` as colcon or ``pip install .`` would."""
    share = root / "share" / paths.PACKAGE_NAME
    (share / "config").mkdir(parents=True)
    (share / "config" / paths.DEFAULT_SCENE_FILE).write_text("bodies: {}\n")
    marker = root / "share" / "ament_index" / "resource_index" / "packages"
    marker.mkdir(parents=True)
    (marker / paths.PACKAGE_NAME).touch()
    return share


def test_source_tree_wins_when_running_from_the_repository() -> None:
    # The tests run from the checkout (editable install or plain source tree).
    assert paths.share_dir() == REPO_ROOT
    assert paths.config_dir() == REPO_ROOT / "config"


def test_default_scene_is_the_repository_file() -> None:
    assert paths.default_scene_path() == REPO_ROOT / "config" / paths.DEFAULT_SCENE_FILE


def test_ament_share_dir_is_used_outside_a_source_tree(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    share = _fake_prefix(tmp_path)
    monkeypatch.setattr(paths, "_source_share_dir", lambda: None)
    monkeypatch.setenv("AMENT_PREFIX_PATH", str(tmp_path))
    assert paths.share_dir() == share
    assert paths.default_scene_path() == share / "config" / paths.DEFAULT_SCENE_FILE


def test_prefix_share_dir_is_used_without_ament(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    share = _fake_prefix(tmp_path)
    monkeypatch.setattr(paths, "_source_share_dir", lambda: None)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    monkeypatch.setattr(paths, "_prefix_share_dir", lambda: share)
    assert paths.config_dir() == share / "config"


def test_missing_config_names_every_place_tried(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(paths, "_source_share_dir", lambda: None)
    monkeypatch.delenv("AMENT_PREFIX_PATH", raising=False)
    monkeypatch.setattr(paths, "_prefix_share_dir", lambda: tmp_path / "nowhere")
    with pytest.raises(FileNotFoundError, match=r"looked in .*nowhere/config"):
        paths.config_dir()


def test_missing_default_scene_is_reported(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    share = tmp_path / "share"
    (share / "config").mkdir(parents=True)
    monkeypatch.setattr(paths, "_candidate_share_dirs", lambda: [share])
    with pytest.raises(FileNotFoundError, match=r"default scene .*default_scene\.yaml"):
        paths.default_scene_path()


# --------------------------------------------------------------------------- opening files users name


def test_read_regular_file_reads_a_file_and_bounds_the_size(tmp_path: Path) -> None:
    path = tmp_path / "a.yaml"
    path.write_bytes(b"x" * 100)
    assert paths.read_regular_file(path, 100) == b"x" * 100
    with pytest.raises(paths.FileTooLargeError, match="file is 100 bytes; expected at most 99"):
        paths.read_regular_file(path, 99)


@pytest.mark.parametrize("kind", ["fifo", "directory", "device"])
def test_special_files_are_refused_for_reading_without_blocking(tmp_path: Path, kind: str) -> None:
    import os

    path = {"fifo": tmp_path / "f", "directory": tmp_path, "device": Path("/dev/zero")}[kind]
    if kind == "fifo":
        os.mkfifo(path)
    expected = {"fifo": "a FIFO", "directory": "a directory", "device": "a character device"}[kind]
    with pytest.raises(paths.NotRegularFileError, match=f"not a regular file \\({expected}\\); expected a YAML file"):
        paths.read_regular_file(path, 10, expected="a YAML file")
    with pytest.raises(paths.NotRegularFileError):
        paths.open_for_reading(path)


def test_open_for_writing_truncates_only_a_regular_file(tmp_path: Path) -> None:
    import os

    path = tmp_path / "out.csv"
    path.write_text("old contents\n")
    with paths.open_for_writing(path) as f:
        f.write(b"new\n")
    assert path.read_bytes() == b"new\n"
    fifo = tmp_path / "out.fifo"
    os.mkfifo(fifo)
    reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)  # with a reader the open would succeed: fstat refuses it
    try:
        with pytest.raises(paths.NotRegularFileError, match=r"\(a FIFO\)"):
            paths.open_for_writing(fifo)
        assert os.read(reader, 10) == b""
    finally:
        os.close(reader)
    with pytest.raises(paths.NotRegularFileError, match=r"\(a character device\)"):
        paths.open_for_writing("/dev/full")
    with pytest.raises(FileNotFoundError):
        paths.open_for_writing(tmp_path / "missing" / "out.csv")


def test_check_writable_path_says_why(tmp_path: Path) -> None:
    import os

    assert paths.check_writable_path(tmp_path / "new.csv") is None
    assert "is a directory" in paths.check_writable_path(tmp_path)
    assert "does not exist" in paths.check_writable_path(tmp_path / "missing" / "x.csv")
    os.mkfifo(tmp_path / "f")
    assert paths.check_writable_path(tmp_path / "f", expected="an .mcap file") == (
        f"{str(tmp_path / 'f')!r} is a FIFO; expected the path of an .mcap file to write")
    assert "is a character device" in paths.check_writable_path("/dev/null")


def test_same_file_follows_links(tmp_path: Path) -> None:
    import os

    a = tmp_path / "a.csv"
    a.write_text("x")
    (tmp_path / "link").symlink_to(a)
    os.link(a, tmp_path / "hard")
    assert paths.same_file(a, tmp_path / "link") and paths.same_file(a, tmp_path / "hard")
    assert paths.same_file(tmp_path / "new", tmp_path / "." / "new")  # neither exists: the same path
    assert not paths.same_file(a, tmp_path / "b.csv")
