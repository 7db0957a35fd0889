"""Tests of rigid_body_sim.package_data (the default scene, found as package data) and
rigid_body_sim.safe_open (opening the files users name without blocking or truncating)."""

from __future__ import annotations

import importlib.resources
from pathlib import Path

import pytest

from rigid_body_sim import package_data, safe_open

REPO_ROOT = Path(__file__).resolve().parent.parent


def test_default_scene_is_the_repository_file_in_a_checkout() -> None:
    # The tests run from the checkout (editable install): the package data is config/ itself.
    assert package_data.default_scene_path() == REPO_ROOT / "config" / package_data.DEFAULT_SCENE_FILE
    assert package_data.config_dir() == REPO_ROOT / "config"


def test_default_scene_is_found_with_importlib_resources(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """Wherever the imported package is installed (a wheel, a colcon install), the scene is taken
    from the config/ inside it."""
    installed = tmp_path / "site-packages" / "rigid_body_sim"
    (installed / "config").mkdir(parents=True)
    (installed / "config" / package_data.DEFAULT_SCENE_FILE).write_text("bodies: {}\n")
    (tmp_path / "site-packages" / "config").mkdir()  # another package's config/ beside it is not looked at
    (tmp_path / "site-packages" / "config" / package_data.DEFAULT_SCENE_FILE).write_text("bodies: {}\n")
    monkeypatch.setattr(package_data, "files", lambda package: installed if package == "rigid_body_sim" else None)
    assert package_data.default_scene_path() == installed / "config" / package_data.DEFAULT_SCENE_FILE


def test_a_develop_install_reads_config_beside_the_package(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """`setup.py develop` (colcon --symlink-install) does not apply package_dir: no config/ inside
    the package, the source tree's beside it."""
    source = tmp_path / "src" / "rigid_body_sim"
    (source / "rigid_body_sim").mkdir(parents=True)
    (source / "config").mkdir()
    (source / "config" / package_data.DEFAULT_SCENE_FILE).write_text("bodies: {}\n")
    monkeypatch.setattr(package_data, "files", lambda package: source / "rigid_body_sim")
    assert package_data.default_scene_path() == source / "config" / package_data.DEFAULT_SCENE_FILE


def test_missing_default_scene_is_reported(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "rigid_body_sim").mkdir()
    monkeypatch.setattr(package_data, "files", lambda package: tmp_path / "rigid_body_sim")
    with pytest.raises(FileNotFoundError, match=r"default scene .*default_scene\.yaml is not installed"):
        package_data.default_scene_path()


def test_setup_ships_config_as_package_data_and_as_shared_files() -> None:
    text = (REPO_ROOT / "setup.py").read_text()
    assert 'package_dir={package_name + ".config": "config"}' in text
    assert 'package_data={package_name + ".config": ["*.yaml"]}' in text
    assert '("share/" + package_name + "/config", sorted(glob("config/*.yaml")))' in text
    assert importlib.resources.files("rigid_body_sim.config").joinpath("default_scene.yaml").is_file()


# --------------------------------------------------------------------------- opening files users name


def test_read_regular_file_reads_a_file_and_bounds_the_size(tmp_path: Path) -> None:
    path = tmp_path / "a.yaml"
    path.write_bytes(b"x" * 100)
    assert safe_open.read_regular_file(path, 100) == b"x" * 100
    with pytest.raises(safe_open.FileTooLargeError, match="file is 100 bytes; expected at most 99"):
        safe_open.read_regular_file(path, 99)


@pytest.mark.parametrize("kind", ["fifo", "directory", "device"])
def test_special_files_are_refused_for_reading_without_blocking(tmp_path: Path, kind: str) -> None:
    import os

    path = {"fifo": tmp_path / "f", "directory": tmp_path, "device": Path("/dev/zero")}[kind]
    if kind == "fifo":
        os.mkfifo(path)
    expected = {"fifo": "a FIFO", "directory": "a directory", "device": "a character device"}[kind]
    with pytest.raises(safe_open.NotRegularFileError, match=f"not a regular file \\({expected}\\); expected a YAML file"):
        safe_open.read_regular_file(path, 10, expected="a YAML file")
    with pytest.raises(safe_open.NotRegularFileError):
        safe_open.open_for_reading(path)


def test_open_for_writing_truncates_only_a_regular_file(tmp_path: Path) -> None:
    import os

    path = tmp_path / "out.csv"
    path.write_text("old contents\n")
    with safe_open.open_for_writing(path) as f:
        f.write(b"new\n")
    assert path.read_bytes() == b"new\n"
    fifo = tmp_path / "out.fifo"
    os.mkfifo(fifo)
    reader = os.open(fifo, os.O_RDONLY | os.O_NONBLOCK)  # with a reader the open would succeed: fstat refuses it
    try:
        with pytest.raises(safe_open.NotRegularFileError, match=r"\(a FIFO\)"):
            safe_open.open_for_writing(fifo)
        assert os.read(reader, 10) == b""
    finally:
        os.close(reader)
    with pytest.raises(safe_open.NotRegularFileError, match=r"\(a character device\)"):
        safe_open.open_for_writing("/dev/full")
    with pytest.raises(FileNotFoundError):
        safe_open.open_for_writing(tmp_path / "missing" / "out.csv")


def test_check_writable_path_says_why(tmp_path: Path) -> None:
    import os

    assert safe_open.check_writable_path(tmp_path / "new.csv") is None
    assert "is a directory" in safe_open.check_writable_path(tmp_path)
    assert "does not exist" in safe_open.check_writable_path(tmp_path / "missing" / "x.csv")
    os.mkfifo(tmp_path / "f")
    assert safe_open.check_writable_path(tmp_path / "f", expected="an .mcap file") == (
        f"{str(tmp_path / 'f')!r} is a FIFO; expected the path of an .mcap file to write")
    assert "is a character device" in safe_open.check_writable_path("/dev/null")


def test_same_file_follows_links(tmp_path: Path) -> None:
    import os

    a = tmp_path / "a.csv"
    a.write_text("x")
    (tmp_path / "link").symlink_to(a)
    os.link(a, tmp_path / "hard")
    assert safe_open.same_file(a, tmp_path / "link") and safe_open.same_file(a, tmp_path / "hard")
    assert safe_open.same_file(tmp_path / "new", tmp_path / "." / "new")  # neither exists: the same path
    assert not safe_open.same_file(a, tmp_path / "b.csv")


def test_create_new_file_never_touches_an_existing_path(tmp_path: Path) -> None:
    import os

    path = tmp_path / "new.mcap"
    made = safe_open.create_new_file(path)
    assert path.read_bytes() == b"" and os.stat(path).st_ino == made.st_ino
    path.write_text("kept\n")
    with pytest.raises(FileExistsError):
        safe_open.create_new_file(path)
    assert path.read_text() == "kept\n"
    os.mkfifo(tmp_path / "f")
    with pytest.raises(FileExistsError):
        safe_open.create_new_file(tmp_path / "f")
    (tmp_path / "dangling").symlink_to(tmp_path / "elsewhere")
    with pytest.raises(FileExistsError):
        safe_open.create_new_file(tmp_path / "dangling")
    assert not (tmp_path / "elsewhere").exists()
