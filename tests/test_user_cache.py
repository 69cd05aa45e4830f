"""The user cache comes from platformdirs and honours ``XDG_CACHE_HOME`` (issue 29, item 5).

``gearsym.engine.trust.user_cache_dir`` is the one place a user folder is computed: the
build cache (:func:`gearsym.facade.default_generated_dir`), the signing key and the shared
driver objects (:func:`gearsym.engine.build.driver_cache_dir`) all follow it.  An absolute
``XDG_CACHE_HOME`` is used; a relative one is ignored, as the XDG specification says (a
relative folder would depend on where gearsym runs); without it, ``$HOME/.cache``.
"""

from __future__ import annotations

import os
from pathlib import Path

import platformdirs
import pytest

from gearsym.engine import build as engine_build
from gearsym.engine import trust
from gearsym.facade import default_generated_dir


@pytest.fixture
def env(tmp_path, monkeypatch):
    home = tmp_path / "home"
    home.mkdir(mode=0o700)
    monkeypatch.setenv("HOME", str(home))
    for name in ("XDG_CACHE_HOME", "GEARSYM_GENERATED", "GEARSYM_DRIVER_CACHE"):
        monkeypatch.delenv(name, raising=False)
    return home


def test_absolute_xdg_cache_home_is_used_everywhere(env, tmp_path, monkeypatch):
    xdg = tmp_path / "xdg"
    monkeypatch.setenv("XDG_CACHE_HOME", str(xdg))
    assert trust.user_cache_dir() == xdg / "gearsym" == Path(platformdirs.user_cache_dir("gearsym"))
    assert default_generated_dir() == xdg / "gearsym"
    assert engine_build.driver_cache_dir(tmp_path / "fallback") == xdg / "gearsym" / "driver"
    key = trust.signing_key()
    assert (xdg / "gearsym" / trust.KEY_FILE).read_bytes() == key
    assert not (env / ".cache").exists()  # nothing in the home folder's default cache


@pytest.mark.parametrize("value", ["relative/cache", "./cache", "~/cache", ""])
def test_relative_or_empty_xdg_cache_home_is_ignored(env, tmp_path, monkeypatch, value):
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("XDG_CACHE_HOME", value)
    assert trust.user_cache_dir() == env / ".cache" / "gearsym"
    assert default_generated_dir() == env / ".cache" / "gearsym"


def test_without_xdg_cache_home_the_home_cache(env):
    assert trust.user_cache_dir() == env / ".cache" / "gearsym"
    assert trust.user_cache_dir().is_absolute()


def test_gearsym_generated_and_driver_cache_still_win(env, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.setenv("GEARSYM_GENERATED", str(tmp_path / "builds"))
    monkeypatch.setenv("GEARSYM_DRIVER_CACHE", str(tmp_path / "drivers"))
    assert default_generated_dir() == tmp_path / "builds"
    assert engine_build.driver_cache_dir(tmp_path / "fallback") == tmp_path / "drivers"


def test_user_cache_dir_creates_nothing(env, tmp_path, monkeypatch):
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    trust.user_cache_dir()
    assert not os.path.lexists(tmp_path / "xdg")  # made and checked only by open_secure_directory
