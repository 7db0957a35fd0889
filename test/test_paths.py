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
