"""The build cache cannot hand back a broken, stale or foreign binary, and cannot race.

Each test pins down a defect of issue 10 (items 3-6): a corrupt cached object
(truncated: SIGBUS in dlopen; garbage bytes) is rebuilt; 8 concurrent builders of one
new model all succeed with one build left; a build survives the deletion of the
SUNDIALS libraries it was linked against when another install uses the cache (no
RUNPATH into a venv); ``--force`` rebuilds; the key covers the toolchain; a scene
name cannot put a build folder outside the cache.  Results are compared with those
of an intact build (the same binary must give bit-identical numbers).
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import gearsym
from gearsym.cli import main
from gearsym.codegen.cache import BuildCache, build_key
from gearsym.engine import build as engine_build
from gearsym.errors import CompileError

ROOT = Path(__file__).resolve().parents[1]
KS_SCENE = ROOT / "scenes" / "kahraman_singh.toml"
KS_MODEL = ROOT / "models" / "kahraman_singh.toml"

#: compile the benchmark scene into $GEARSYM_GENERATED, simulate 5 periods, print JSON
SIM = f"""
import json, gearsym
s = gearsym.load_scene({str(KS_SCENE)!r}).compile()
t = s.simulate(periods=5)
print(json.dumps({{"cached": s.generated.cached, "so": s.generated.so_path, "x": t.y[-1].tolist()}}))
"""


def _env(cache: Path, **extra: str) -> dict[str, str]:
    return dict(os.environ, GEARSYM_GENERATED=str(cache), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1",
                **extra)


def _py(code: str, cache: Path, **extra: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env(cache, **extra),
                          timeout=900)


def _only_build(cache: Path) -> Path:
    """The one build folder of ``cache``; asserts there is nothing else (no leftovers)."""
    entries = sorted(cache.iterdir())
    assert len(entries) == 1 and entries[0].is_dir(), [e.name for e in entries]
    files = sorted(f.name for f in entries[0].iterdir())
    assert len(files) == 4 and files[:1] == ["gs_" + files[0][3:]] and files[0].endswith(".so"), files
    assert files[1:] == ["gs_model.c", "gs_model.h", "meta.json"], files
    return entries[0]


@pytest.fixture
def built(tmp_path):
    """A cache with the benchmark scene built by another process, and that run's result."""
    cache = tmp_path / "cache"
    r = _py(SIM, cache)
    assert r.returncode == 0, r.stderr
    return cache, json.loads(r.stdout)


def test_truncated_object_is_rebuilt_in_a_fresh_process(built):
    # before: the cache trusted any existing gs_*.so and dlopen died with SIGBUS (exit 135)
    cache, ref = built
    so = next(cache.glob("*/gs_*.so"))
    os.truncate(so, so.stat().st_size // 2)
    r = _py(SIM, cache)
    assert r.returncode == 0, f"exit {r.returncode}: {r.stderr[-2000:]}"
    out = json.loads(r.stdout)
    assert not out["cached"] and out["x"] == ref["x"]
    _only_build(cache)
    r = _py(SIM, cache)  # and the rebuilt one is reused
    assert r.returncode == 0 and json.loads(r.stdout)["cached"]


def test_garbage_object_is_rebuilt_in_the_same_process(built):
    # before: "cannot load the compiled model ...: invalid ELF header", and it stayed cached
    cache, ref = built
    so = next(cache.glob("*/gs_*.so"))
    so.write_bytes(os.urandom(so.stat().st_size))
    system = gearsym.load_scene(KS_SCENE).compile(generated_dir=cache)
    assert not system.generated.cached
    assert system.simulate(periods=5).y[-1].tolist() == ref["x"]
    _only_build(cache)
    r = _py(SIM, cache)
    assert r.returncode == 0 and json.loads(r.stdout)["cached"], r.stderr
    # a damaged meta.json is a build that does not verify, too
    meta = next(cache.glob("*/meta.json"))
    meta.write_text(meta.read_text()[:100])
    system = gearsym.load_scene(KS_SCENE).compile(generated_dir=cache)
    assert not system.generated.cached and system.simulate(periods=5).y[-1].tolist() == ref["x"]
    _only_build(cache)


BUILDER = f"""
import json, os, sys, time
import gearsym
print("ready", flush=True)
while not os.path.exists(sys.argv[1]):
    time.sleep(0.002)
s = gearsym.load_scene({str(KS_SCENE)!r}).compile()
t = s.simulate(periods=2)
print(json.dumps({{"so": s.generated.so_path, "cached": s.generated.cached, "x": t.y[-1].tolist()}}))
"""


def test_eight_concurrent_builders_make_one_build(tmp_path):
    # before: FileNotFoundError / "Directory not empty" in the shared _cg/ folder, "does not
    # export gs_model_info", leftover _cg/ folders and duplicate .so files
    cache, go = tmp_path / "cache", tmp_path / "go"
    procs = [subprocess.Popen([sys.executable, "-c", BUILDER, str(go)], stdout=subprocess.PIPE,
                              stderr=subprocess.PIPE, text=True, env=_env(cache)) for _ in range(8)]
    try:
        for p in procs:  # all imported gearsym: start them together
            assert p.stdout.readline().strip() == "ready", p.stderr.read()
        go.touch()
        outs = [p.communicate(timeout=900) for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    failed = [(p.returncode, err[-1500:]) for p, (_, err) in zip(procs, outs) if p.returncode != 0]
    assert not failed, failed
    res = [json.loads(out) for out, _ in outs]
    assert len({r["so"] for r in res}) == 1
    assert sum(not r["cached"] for r in res) == 1  # one builder built, seven waited and reused
    assert all(r["x"] == res[0]["x"] for r in res)
    _only_build(cache)


def _fake_install(site: Path) -> Path:
    """A second 'install' of scikit-sundae: a package folder and copies of its SUNDIALS
    libraries, found first through PYTHONPATH (all that gearsym uses of the wheel)."""
    libs = engine_build.find_sundials_libs()
    (site / "sksundae").mkdir(parents=True)
    (site / "sksundae" / "__init__.py").write_text("")
    (site / "scikit_sundae.libs").mkdir()
    for p in libs.libs:
        shutil.copy2(p, site / "scikit_sundae.libs" / p.name)
    return site


def test_build_survives_the_deletion_of_the_libraries_it_was_linked_against(tmp_path):
    # before: each .so had a RUNPATH into the building venv; with that venv gone, another
    # install reused the build and failed with "libsundials_cvode-....so.7.9.0: cannot open
    # shared object file" (this failed `make test` on a fresh clone)
    cache = tmp_path / "cache"
    a = _fake_install(tmp_path / "install_a")
    r = _py(SIM, cache, PYTHONPATH=str(a))
    assert r.returncode == 0, r.stderr
    ref = json.loads(r.stdout)
    shutil.rmtree(a)
    b = _fake_install(tmp_path / "install_b")
    r = _py(SIM, cache, PYTHONPATH=str(b))
    assert r.returncode == 0, r.stderr[-2000:]
    out = json.loads(r.stdout)
    assert out["cached"] and out["so"] == ref["so"] and out["x"] == ref["x"]  # same libraries: reused
    assert str(a) not in Path(ref["so"]).read_bytes().decode("latin-1")  # no path into an install
    _only_build(cache)


def test_key_covers_libraries_compiler_and_model(tmp_path, monkeypatch):
    text = KS_MODEL.read_text()
    eff = gearsym.load_scene(KS_SCENE).resolved.effects
    k0, parts = build_key(text, eff, "explicit")
    assert len(k0) == 64 and parts["casadi"] and parts["toolchain"]["compiler_version"]
    assert build_key(text, eff, "explicit")[0] == k0
    assert build_key(text + "\n# comment", eff, "explicit")[0] != k0
    assert build_key(text, {**eff, "backlash": False}, "explicit")[0] != k0
    # other SUNDIALS libraries (one byte more in one of them)
    site = _fake_install(tmp_path / "site")
    libdir = site / "scikit_sundae.libs"
    with open(next(libdir.glob("libsundials_cvode-*")), "ab") as f:
        f.write(b"\0")
    monkeypatch.setattr(engine_build, "_sksundae_dir", lambda: site / "sksundae")
    assert build_key(text, eff, "explicit")[0] != k0
    monkeypatch.undo()
    # another compiler (a wrapper reporting another version)
    cc = tmp_path / "cc-wrapper"
    cc.write_text(f'#!/bin/sh\n[ "$1" = --version ] && {{ echo "other cc 99"; exit 0; }}\n'
                  f'exec {engine_build.resolve_compiler()} "$@"\n')
    cc.chmod(0o755)
    monkeypatch.setenv("CC", str(cc))
    assert build_key(text, eff, "explicit")[0] != k0


def test_force_rebuilds(tmp_path, capsys, monkeypatch):
    # before: `compile --force` printed "reused cached build" and kept the old object
    gen = gearsym.load_scene(KS_SCENE).generate(generated_dir=tmp_path)
    so = Path(gen.so_path)
    ino = so.stat().st_ino
    again = gearsym.load_scene(KS_SCENE).generate(generated_dir=tmp_path)
    assert again.cached and Path(again.so_path).stat().st_ino == ino
    monkeypatch.setenv("GEARSYM_GENERATED", str(tmp_path))
    assert main(["compile", str(KS_SCENE), "--force", "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["cached"] is False and info["compile_seconds"] > 0
    assert Path(info["shared_object"]).stat().st_ino != ino  # a new file
    _only_build(tmp_path)


@pytest.mark.parametrize("name", ["../../../x", "/abs/path", "..", ".", "a/../../b", "~", "x" * 500, "\n*/"])
def test_build_folder_stays_inside_the_cache(tmp_path, name):
    cache = BuildCache(tmp_path / "c")
    e = cache.entry(name, "0123456789abcdef" * 4)
    assert e.directory.parent == tmp_path / "c" and e.directory.name.endswith("-0123456789abcdef")
    assert len(e.directory.name) <= 81 and not e.directory.name.startswith(".")


def test_build_folder_through_a_symlink_is_refused(tmp_path):
    cache = BuildCache(tmp_path / "c")
    key = "0123456789abcdef" * 4
    (tmp_path / "c").mkdir()
    (tmp_path / "elsewhere").mkdir()
    cache.entry("s", key).directory.symlink_to(tmp_path / "elsewhere")
    with pytest.raises(CompileError, match="not a folder directly inside the build cache"):
        cache.entry("s", key)


def test_scene_name_with_path_builds_inside_the_cache(tmp_path):
    # before: [scene] name = "../../x" created the build folder outside the cache.  The spec layer
    # now rejects such a name; the build layer still keeps any name inside the cache (defense in
    # depth, tested by handing it a scene whose name bypassed the spec check)
    import dataclasses

    from gearsym.errors import SpecError

    scene = tmp_path / "scenes" / "s.toml"
    scene.parent.mkdir()
    scene.write_text(KS_SCENE.read_text().replace('name = "kahraman_singh"', 'name = "../../escaped"')
                     .replace('"../models/kahraman_singh.toml"', json.dumps(str(KS_MODEL))))
    with pytest.raises(SpecError, match="scene.name"):
        gearsym.load_scene(scene)
    sc = gearsym.load_scene(KS_SCENE)
    sc.spec = dataclasses.replace(sc.spec, name="../../escaped")
    cache = tmp_path / "a" / "b" / "cache"
    gen = sc.generate(generated_dir=cache)
    assert Path(gen.directory).parent == cache and not (tmp_path / "a" / "escaped").exists()
    assert sorted(p.name for p in tmp_path.rglob("*escaped*")) == [Path(gen.directory).name]


def test_cache_command_path_list_clear(tmp_path, capsys, monkeypatch):
    monkeypatch.setenv("GEARSYM_GENERATED", str(tmp_path / "c"))
    gen = gearsym.load_scene(KS_SCENE).generate()
    assert main(["cache", "path"]) == 0
    assert capsys.readouterr().out.strip() == str(tmp_path / "c")
    assert main(["cache", "path", str(KS_SCENE), "--json"]) == 0
    info = json.loads(capsys.readouterr().out)
    assert info["build"] == gen.directory and info["built"] and info["key"] == gen.build_key
    assert main(["cache", "list", "--json"]) == 0
    [b] = json.loads(capsys.readouterr().out)["builds"]
    assert (b["scene"], b["model"], b["key"], b["complete"]) == ("kahraman_singh", "kahraman_singh",
                                                                 gen.build_key, True)
    assert b["size_bytes"] == sum(f.stat().st_size for f in Path(gen.directory).iterdir())
    assert main(["cache", "clear", "--older-than", "1"]) == 0  # built just now: kept
    assert Path(gen.directory).is_dir()
    assert main(["cache", "clear", "other_scene"]) == 0  # another scene's: kept
    assert Path(gen.directory).is_dir()
    capsys.readouterr()
    assert main(["cache", "clear", "kahraman_singh", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [r["directory"] for r in out["removed"]] == [gen.directory] and out["freed_bytes"] == b["size_bytes"]
    assert list((tmp_path / "c").iterdir()) == []
    # a file that is not a build is never removed
    (tmp_path / "c" / "notes.txt").write_text("mine")
    assert main(["cache", "clear"]) == 0
    assert (tmp_path / "c" / "notes.txt").read_text() == "mine"
    assert main(["cache", "clear", "--older-than", "-1"]) == 2
    assert "--older-than" in capsys.readouterr().err


def test_compiler_writing_garbage_leaves_no_build(tmp_path, monkeypatch):
    # before: the garbage object was cached and every later run failed to load it
    cc = tmp_path / "bad-cc"
    cc.write_text(f'#!/bin/sh\n{engine_build.resolve_compiler()} "$@" || exit $?\n'
                  'while [ $# -gt 0 ]; do [ "$1" = -o ] && head -c 5000 /dev/urandom > "$2"; shift; done\n')
    cc.chmod(0o755)
    monkeypatch.setenv("CC", str(cc))
    with pytest.raises(CompileError, match="cannot load|invalid ELF|damaged"):
        gearsym.load_scene(KS_SCENE).generate(generated_dir=tmp_path / "cache")
    assert not (tmp_path / "cache").exists() or list((tmp_path / "cache").iterdir()) == []


def test_sources_digest_covers_modules_in_subpackages(tmp_path, monkeypatch):
    """An edit to an element module (``symbolic/elements/*.py``) changes the build key: the
    digest covers every module below spec/, symbolic/ and codegen/, not only the top level."""
    import shutil

    from gearsym.codegen import cache

    pkg = Path(cache.__file__).resolve().parent.parent
    for sub in cache._SOURCE_DIRS:
        shutil.copytree(pkg / sub, tmp_path / sub, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(cache, "_PKG", tmp_path)
    cache._sources_digest.cache_clear()
    try:
        before = cache._sources_digest()
        element = tmp_path / "symbolic" / "elements" / "base.py"
        element.write_text(element.read_text() + "\n# an edit\n")
        cache._sources_digest.cache_clear()
        assert cache._sources_digest() != before
    finally:
        cache._sources_digest.cache_clear()
