"""Only this user's gearsym's builds are loaded, from folders no other user can change (issue 25, items 1-4).

Each test pins down a probe of a hostile folder: a paper's supplement that ships
``generated/`` with a planted build next to its ``scenes/`` (item 1), a real build copied
from another user's cache (another signing key), a world-writable ancestor, a planted
lock-file symbolic link (item 2), ``cache clear`` in a folder holding the user's own
folders named like builds (item 3), a truncated shared driver object (item 4), and the
rest of an attacker's kit: symbolic links for the cache root, the build folder, its
files and the key; hard links; group- and world-writable folders and files; a huge or
FIFO ``meta.json``; a key file other users can read or that another user owns.

One build of the benchmark scene (module fixture) is copied where a test needs one;
tests that need another user use ``chown`` and are skipped unless run as root.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import re
import shutil
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

import gearsym
from gearsym.cli import main
from gearsym.codegen.cache import BuildCache
from gearsym.engine import build as engine_build
from gearsym.errors import CompileError

ROOT = Path(__file__).resolve().parents[1]
KS_SCENE = ROOT / "scenes" / "kahraman_singh.toml"
KS_MODEL = ROOT / "models" / "kahraman_singh.toml"
OTHER_UID = 54321  # a user id nobody on the test machine has (chown needs root)
as_root = pytest.mark.skipif(os.geteuid() != 0, reason="making a file another user's needs root")


def _user_cache() -> Path:
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg and os.path.isabs(xdg) else Path.home() / ".cache") / "gearsym"


@pytest.fixture(scope="module")
def ks(tmp_path_factory):
    """One build of the benchmark scene (made by this user's gearsym): its folder and key."""
    cache = tmp_path_factory.mktemp("ks") / "cache"
    gen = gearsym.load_scene(KS_SCENE).generate(generated_dir=cache)
    return Path(gen.directory), gen.build_key


def _copy(build: Path, root: Path, name: str | None = None) -> Path:
    root.mkdir(parents=True, exist_ok=True)
    return Path(shutil.copytree(build, root / (name or build.name)))


def _lookup(root: Path, build: Path, key: str):
    cache = BuildCache(root)
    return cache.lookup(cache.entry(build.name[:-17], key), key)


@pytest.fixture
def other_key(tmp_path, monkeypatch):
    """Run as a user with another signing key (another XDG_CACHE_HOME, another key file)."""
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "other-user-cache"))
    monkeypatch.setenv("GEARSYM_DRIVER_CACHE", str(tmp_path / "other-user-cache" / "driver"))
    return tmp_path / "other-user-cache"


# ------------------------------------------------------------------ item 1: planted builds
PLANTED_C = """
#include <stdio.h>
static const char key_text[] = "gearsym-build-key:{key}";
const char* gs_build_key(void) {{ return key_text + 18; }}
__attribute__((constructor)) static void planted(void) {{
  FILE* f = fopen("{marker}", "w");
  if (f) {{ fputs("the planted code ran", f); fclose(f); }}
}}
"""


def _plant(build: Path, key: str, folder: Path, marker: Path) -> Path:
    """A build folder in ``folder`` whose object writes ``marker`` when loaded, with the real
    build's meta.json (its signature too) naming the planted object and its SHA-256."""
    d = folder / build.name
    d.mkdir(parents=True)
    (d / "planted.c").write_text(PLANTED_C.format(key=key, marker=marker))
    subprocess.run([engine_build.resolve_compiler(), "-shared", "-fPIC", "-o", str(d / "x.so"), str(d / "planted.c")],
                   check=True)
    data = (d / "x.so").read_bytes()
    sha = hashlib.sha256(data).hexdigest()
    so = d / f"gs_{sha[:16]}.so"
    (d / "x.so").rename(so)
    for f in ("gs_model.c", "gs_model.h"):
        shutil.copy(build / f, d / f)
    meta = json.loads((build / "meta.json").read_text())
    meta.update(so_path=str(so), so_sha256=sha, directory=str(d))
    (d / "meta.json").write_text(json.dumps(meta))
    return d


def _supplement(tmp_path: Path, ks) -> tuple[Path, Path, Path]:
    """A downloaded folder: scenes/, models/ and generated/ with a planted build."""
    build, key = ks
    sup = tmp_path / "supplement"
    (sup / "scenes").mkdir(parents=True)
    (sup / "models").mkdir()
    shutil.copy(KS_SCENE, sup / "scenes" / KS_SCENE.name)
    shutil.copy(KS_MODEL, sup / "models" / KS_MODEL.name)
    marker = tmp_path / "PLANTED_CODE_RAN"
    planted = _plant(build, key, sup / "generated", marker)
    return sup, marker, planted


def _gearsym(args: list[str], **env: str) -> subprocess.CompletedProcess:
    e = {k: v for k, v in os.environ.items() if k != "GEARSYM_GENERATED"}
    e.update(OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", **env)
    return subprocess.run([sys.executable, "-m", "gearsym", *args], capture_output=True, text=True, env=e,
                          timeout=900)


def test_planted_build_next_to_the_scenes_never_runs(tmp_path, ks, monkeypatch):
    # before: the nearest generated/ above the scene was the cache; the planted object's key
    # and SHA-256 matched its own meta.json, so it was loaded and its constructor ran
    sup, marker, planted = _supplement(tmp_path, ks)
    r = _gearsym(["simulate", str(sup / "scenes" / KS_SCENE.name), "--periods", "2", "--json"])
    assert not marker.exists(), "the planted code ran"
    assert r.returncode == 0, r.stderr[-2000:]
    monkeypatch.delenv("GEARSYM_GENERATED", raising=False)
    gen = gearsym.load_scene(sup / "scenes" / KS_SCENE.name).generate()
    assert gen.cached and Path(gen.directory).parent == _user_cache()  # where the user's builds go
    assert (planted / "planted.c").exists() and len(list(planted.glob("gs_*.so"))) == 1  # left alone


def test_planted_build_in_a_folder_named_on_purpose_never_runs(tmp_path, ks):
    # the user names the supplement's generated/ as the cache: its planted build, whatever its
    # meta.json says (even the signature copied from a real build), is rebuilt, never loaded
    sup, marker, planted = _supplement(tmp_path, ks)
    (tmp_path / "outside").mkdir()
    (tmp_path / "outside" / "thesis.tex").write_text("mine")
    (planted / "data").symlink_to(tmp_path / "outside")  # removing the planted folder must not follow it
    r = _gearsym(["simulate", str(sup / "scenes" / KS_SCENE.name), "--periods", "2", "--json"],
                 GEARSYM_GENERATED=str(sup / "generated"))
    assert not marker.exists(), "the planted code ran"
    assert r.returncode == 0, r.stderr[-2000:]
    assert not (planted / "planted.c").exists()  # replaced by a build of ours
    assert (tmp_path / "outside" / "thesis.tex").read_text() == "mine"
    gen = _lookup(sup / "generated", planted, ks[1])
    assert gen is not None and Path(gen.so_path).parent == planted


def test_a_real_build_from_another_users_cache_is_never_loaded(tmp_path, ks, other_key):
    # a genuine build made by gearsym, copied from a cache signed with another key
    build, key = ks
    folder = tmp_path / "colleague" / "generated"
    copy = _copy(build, folder)
    assert _lookup(folder, copy, key) is None  # another key: refused before anything is loaded
    ino = next(copy.glob("gs_*.so")).stat().st_ino
    gen = gearsym.load_scene(KS_SCENE).generate(generated_dir=folder)
    assert not gen.cached and Path(gen.directory) == copy  # rebuilt in place, by this user
    assert next(copy.glob("gs_*.so")).stat().st_ino != ino
    assert _lookup(folder, copy, key) is not None


def test_the_build_of_this_user_verifies(tmp_path, ks):
    build, key = ks
    assert _lookup(tmp_path / "c", _copy(build, tmp_path / "c"), key) is not None  # a copy of one's own build
    meta = json.loads((build / "meta.json").read_text())
    assert set(meta["signature"]["files"]) == {Path(meta["so_path"]).name, "gs_model.c", "gs_model.h"}


@pytest.mark.parametrize("change", ["so", "source", "meta", "signature", "no_signature"])
def test_a_changed_byte_anywhere_fails_verification(tmp_path, ks, change):
    build, key = ks
    d = _copy(build, tmp_path / "c")
    meta_path = d / "meta.json"
    meta = json.loads(meta_path.read_text())
    if change == "so":
        so = next(d.glob("gs_*.so"))
        data = bytearray(so.read_bytes())
        data[-1] ^= 1
        so.write_bytes(bytes(data))
    elif change == "source":  # the exported C program and FMU copy gs_model.c
        with open(d / "gs_model.c", "a") as f:
            f.write("\n/* planted */\n")
    elif change == "meta":  # the serialised CasADi functions are read from meta.json
        meta["state_names"] = meta["state_names"][::-1]
        meta_path.write_text(json.dumps(meta))
    elif change == "signature":
        meta["signature"]["hmac"] = "0" * 64
        meta_path.write_text(json.dumps(meta))
    else:
        del meta["signature"]
        meta_path.write_text(json.dumps(meta))
    assert _lookup(tmp_path / "c", d, key) is None


def test_world_writable_ancestor_is_never_the_cache(tmp_path, monkeypatch, capsys):
    # before: /shared/generated/ (a shared temporary folder's) was the cache of every scene below it
    shared = tmp_path / "shared"
    (shared / "generated").mkdir(parents=True)
    (shared / "proj" / "scenes").mkdir(parents=True)
    shared.chmod(0o777)
    scene = shared / "proj" / "scenes" / "ks.toml"
    scene.write_text(KS_SCENE.read_text().replace('"../models/kahraman_singh.toml"', json.dumps(str(KS_MODEL))))
    monkeypatch.delenv("GEARSYM_GENERATED", raising=False)
    from gearsym.facade import default_generated_dir

    assert default_generated_dir(scene) == _user_cache()
    # named on purpose, it is refused: exit 2, naming the folder and the reason, nothing built
    monkeypatch.setenv("GEARSYM_GENERATED", str(shared / "generated"))
    assert main(["compile", str(scene)]) == 2
    err = capsys.readouterr().err
    assert f"{shared} is writable by other users (mode 0o777, no sticky bit)" in err
    assert list((shared / "generated").iterdir()) == []


def test_cache_writable_by_others_is_refused(tmp_path, ks):
    build, key = ks
    root = tmp_path / "c"
    _copy(build, root)
    root.chmod(0o777)
    with pytest.raises(CompileError, match=re.escape(f"{root} is writable by other users")):
        _lookup(root, root / build.name, key)
    root.chmod(0o700)
    (root / build.name).chmod(0o777)  # the build folder itself
    assert _lookup(root, root / build.name, key) is None
    root.chmod(0o1777)  # sticky, but the cache itself must be only the user's
    with pytest.raises(CompileError, match="writable by other users"):
        _lookup(root, root / build.name, key)


def test_a_sticky_shared_folder_above_the_cache_is_fine(tmp_path, ks):
    build, key = ks
    (tmp_path / "tmp").mkdir()
    (tmp_path / "tmp").chmod(0o1777)  # as /tmp: others cannot rename what is not theirs
    d = _copy(build, tmp_path / "tmp" / "mine")
    assert _lookup(tmp_path / "tmp" / "mine", d, key) is not None


@as_root
def test_cache_owned_by_another_user_is_refused(tmp_path, ks):
    build, key = ks
    root = tmp_path / "c"
    d = _copy(build, root)
    os.chown(root, OTHER_UID, -1)
    with pytest.raises(CompileError, match=re.escape(f"{root} is owned by uid {OTHER_UID}, not by you")):
        _lookup(root, d, key)
    os.chown(root, 0, -1)
    os.chown(tmp_path, OTHER_UID, -1)  # an ancestor owned by another user (it could rename the cache)
    try:
        with pytest.raises(CompileError, match=re.escape(f"{tmp_path} is owned by uid {OTHER_UID}")):
            _lookup(root, d, key)
    finally:
        os.chown(tmp_path, 0, -1)
    os.chown(d / "meta.json", OTHER_UID, -1)  # a file of another user in the build
    assert _lookup(root, d, key) is None


@as_root
def test_group_writable_cache_of_a_shared_group_is_refused(tmp_path, ks):
    build, key = ks
    root = tmp_path / "c"
    d = _copy(build, root)
    os.chown(root, -1, OTHER_UID)  # a group that is not the user's private group
    root.chmod(0o770)
    with pytest.raises(CompileError, match="writable by other users"):
        _lookup(root, d, key)


def test_symlinked_cache_root_of_the_user_is_followed(tmp_path, ks):
    build, key = ks
    d = _copy(build, tmp_path / "real")
    (tmp_path / "link").symlink_to(tmp_path / "real")
    assert _lookup(tmp_path / "link", tmp_path / "link" / d.name, key) is not None


@as_root
def test_symlinked_cache_root_of_another_user_is_refused(tmp_path, ks):
    build, key = ks
    d = _copy(build, tmp_path / "real")
    (tmp_path / "link").symlink_to(tmp_path / "real")
    os.lchown(tmp_path / "link", OTHER_UID, -1)
    with pytest.raises(CompileError, match=re.escape(f"{tmp_path / 'link'} is a symbolic link owned by uid {OTHER_UID}")):
        _lookup(tmp_path / "link", tmp_path / "link" / d.name, key)


@pytest.mark.parametrize("what", ["so", "meta.json", "gs_model.c"])
def test_symlinked_file_in_a_build_is_never_followed(tmp_path, ks, what):
    build, key = ks
    d = _copy(build, tmp_path / "c")
    f = next(d.glob("gs_*.so")) if what == "so" else d / what
    f.unlink()
    f.symlink_to(build / f.name)  # the intact original: only the link is wrong
    assert _lookup(tmp_path / "c", d, key) is None


def test_hardlink_farm_build_is_refused(tmp_path, ks):
    build, key = ks
    d = tmp_path / "c" / build.name
    d.mkdir(parents=True)
    try:
        for f in build.iterdir():
            os.link(f, d / f.name)
        assert _lookup(tmp_path / "c", d, key) is None
    finally:
        shutil.rmtree(d)  # the module's build has one link again


def test_symlinked_build_folder_is_refused(tmp_path, ks):
    build, key = ks
    (tmp_path / "c").mkdir()
    (tmp_path / "c" / build.name).symlink_to(build)  # a link to a genuine build elsewhere
    with pytest.raises(CompileError, match="not a folder directly inside the build cache"):
        _lookup(tmp_path / "c", tmp_path / "c" / build.name, key)
    (tmp_path / "c" / build.name).unlink()
    (tmp_path / "c" / build.name).symlink_to(build.name)  # a loop
    with pytest.raises(CompileError, match="refusing to build there"):
        _lookup(tmp_path / "c", tmp_path / "c" / build.name, key)


def test_file_writable_by_others_in_a_build_is_refused(tmp_path, ks):
    build, key = ks
    d = _copy(build, tmp_path / "c")
    next(d.glob("gs_*.so")).chmod(0o666)
    assert _lookup(tmp_path / "c", d, key) is None


def test_huge_meta_json_is_not_read(tmp_path, ks):
    import tracemalloc

    from gearsym.codegen.cache import META_LIMIT

    build, key = ks
    d = _copy(build, tmp_path / "c")
    with open(d / "meta.json", "r+b") as f:
        f.truncate(META_LIMIT + 1)  # sparse: no disk used
    tracemalloc.start()
    try:
        assert _lookup(tmp_path / "c", d, key) is None
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 8 << 20


def test_fifo_meta_json_does_not_hang(tmp_path, ks):
    build, key = ks
    d = _copy(build, tmp_path / "c")
    (d / "meta.json").unlink()
    os.mkfifo(d / "meta.json")  # an open for reading would wait for a writer forever
    assert _lookup(tmp_path / "c", d, key) is None
    assert BuildCache(tmp_path / "c").builds()[0].verified is False


# ------------------------------------------------------------------ the signing key
def test_signing_key_is_made_private_and_atomically(tmp_path):
    go = tmp_path / "go"
    code = textwrap.dedent(f"""
        import os, time
        from gearsym.engine.trust import signing_key
        print("ready", flush=True)
        while not os.path.exists({str(go)!r}):
            time.sleep(0.002)
        print(signing_key().hex())
    """)
    env = dict(os.environ, XDG_CACHE_HOME=str(tmp_path / "xdg"))
    procs = [subprocess.Popen([sys.executable, "-c", code], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True, env=env) for _ in range(6)]
    try:
        for p in procs:
            assert p.stdout.readline().strip() == "ready", p.stderr.read()
        go.touch()
        outs = [p.communicate(timeout=300) for p in procs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
    assert all(p.returncode == 0 for p in procs), [e for _, e in outs]
    keys = {o.strip() for o, _ in outs}
    assert len(keys) == 1 and len(keys.pop()) == 64  # one key, 32 bytes, for everyone
    kf = tmp_path / "xdg" / "gearsym" / ".signing-key"
    st = kf.stat()
    assert stat.S_IMODE(st.st_mode) == 0o600 and st.st_uid == os.geteuid() and st.st_nlink == 1
    assert sorted(p.name for p in kf.parent.iterdir()) == [".signing-key"]  # no temporary file left


@pytest.mark.parametrize("plant", ["readable", "symlink", "short", "fifo", pytest.param("owner", marks=as_root)])
def test_unsafe_signing_key_is_refused(tmp_path, monkeypatch, plant):
    from gearsym.engine.trust import UntrustedCacheError, signing_key

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    kdir = tmp_path / "xdg" / "gearsym"
    kdir.mkdir(parents=True)
    kf = kdir / ".signing-key"
    reason = {"readable": r"other users can read or write it \(mode 0o644\)", "symlink": "symbolic link",
              "short": "it has 5 bytes, not 32", "fifo": "not a regular file",
              "owner": f"owned by uid {OTHER_UID}, not by you"}[plant]
    if plant == "symlink":
        (tmp_path / "known").write_bytes(b"k" * 32)
        kf.symlink_to(tmp_path / "known")
    elif plant == "fifo":
        os.mkfifo(kf, 0o600)
    else:
        kf.write_bytes(b"k" * (5 if plant == "short" else 32))
        kf.chmod(0o644 if plant == "readable" else 0o600)
        if plant == "owner":  # planted by another user (who knows it)
            os.chown(kf, OTHER_UID, -1)
    with pytest.raises(UntrustedCacheError, match=reason) as exc:
        signing_key()
    assert str(kf) in str(exc.value) and exc.value.exit_code == 2


@as_root
def test_user_cache_of_another_user_is_refused(tmp_path, monkeypatch):
    # XDG_CACHE_HOME on a shared disk, where another user made gearsym/ first
    from gearsym.engine.trust import UntrustedCacheError, signing_key

    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    (tmp_path / "xdg" / "gearsym").mkdir(parents=True)
    os.chown(tmp_path / "xdg" / "gearsym", OTHER_UID, -1)
    with pytest.raises(UntrustedCacheError, match=f"owned by uid {OTHER_UID}"):
        signing_key()


# ------------------------------------------------------------------ item 2: planted lock links
@pytest.mark.parametrize("victim_exists", [False, True])
def test_planted_lock_symlink_is_never_followed(tmp_path, ks, victim_exists):
    # before: the build opened the planted .<build>.lock link with O_CREAT: it created the file
    # the link points to, anywhere the user can write
    build, key = ks
    cache = tmp_path / "c"
    cache.mkdir()
    victim = tmp_path / "victim"
    if victim_exists:
        victim.write_text("precious")
    (cache / f".{build.name}.lock").symlink_to(victim)
    with pytest.raises(CompileError, match="is a symbolic link"):
        gearsym.load_scene(KS_SCENE).generate(generated_dir=cache)
    assert victim.read_text() == "precious" if victim_exists else not victim.exists()


def test_cache_clear_never_follows_a_planted_lock_symlink(tmp_path, ks):
    build, key = ks
    root = tmp_path / "c"
    d = _copy(build, root)
    victim = tmp_path / "victim"
    (root / f".{d.name}.lock").symlink_to(victim)
    assert BuildCache(root).clear() == []
    assert not victim.exists() and d.is_dir()


def test_cache_clear_never_follows_symlinked_leftovers(tmp_path, ks):
    build, key = ks
    root = tmp_path / "c"
    _copy(build, root)
    (tmp_path / "outside").mkdir()
    (tmp_path / "outside" / "thesis.tex").write_text("mine")
    for prefix in (".tmp", ".trash"):
        (root / f"{prefix}-{build.name}-x").symlink_to(tmp_path / "outside")
    (root / "x-0123456789abcdef").symlink_to(tmp_path / "outside")
    assert [e.directory.name for e in BuildCache(root).clear()] == [build.name]
    assert (tmp_path / "outside" / "thesis.tex").read_text() == "mine"


def _driver_name() -> str:
    """The file name driver_object() gives the driver (its formula, as in gearsym.engine.build)."""
    tc = engine_build.toolchain_identity()
    h = hashlib.sha256(json.dumps([tc["driver"], tc["compiler"], tc["compiler_version"],
                                   list(engine_build.DRIVER_CFLAGS)]).encode())
    return f"gs_driver-{h.hexdigest()[:16]}.o"


def test_planted_driver_lock_symlink_is_never_followed(tmp_path):
    drv = tmp_path / "driver"
    drv.mkdir()
    victim = tmp_path / "victim"
    (drv / f".{_driver_name()}.lock").symlink_to(victim)
    with pytest.raises(CompileError, match="is a symbolic link"):
        engine_build.driver_object(drv)
    assert not victim.exists()


# ------------------------------------------------------------------ item 3: cache clear
def test_cache_clear_removes_only_builds_it_made(tmp_path, ks, monkeypatch, capsys):
    # before: every folder named <name>-<16 hex> was removed, the user's assets-0123456789abcdef/ too
    build, key = ks
    root = tmp_path / "c"
    ours = _copy(build, root)
    (root / "assets-0123456789abcdef").mkdir()
    (root / "assets-0123456789abcdef" / "figure.png").write_bytes(b"mine")
    foreign = _copy(build, root, "other-fedcba9876543210")  # a build folder signed for... nobody here
    meta = json.loads((foreign / "meta.json").read_text())
    meta.pop("signature", None)
    (foreign / "meta.json").write_text(json.dumps(meta))
    leftover = root / ".tmp-thesis-0123456789abcdef-x1"  # named like a killed builder's folder
    leftover.mkdir()
    (leftover / "chapter.tex").write_text("mine")
    monkeypatch.setenv("GEARSYM_GENERATED", str(root))
    assert main(["cache", "list", "--json"]) == 0
    listed = {Path(b["directory"]).name: b.get("verified") for b in json.loads(capsys.readouterr().out)["builds"]}
    assert main(["cache", "clear", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert (root / "assets-0123456789abcdef" / "figure.png").read_bytes() == b"mine"
    assert (leftover / "chapter.tex").read_text() == "mine"
    assert [Path(r["directory"]).name for r in out["removed"]] == [ours.name]
    assert sorted(p.name for p in root.iterdir()) == sorted([leftover.name, "assets-0123456789abcdef", foreign.name])
    assert listed == {ours.name: True, "assets-0123456789abcdef": False, foreign.name: False}


def test_cache_clear_removes_signed_leftovers_of_a_killed_builder(tmp_path, ks):
    build, key = ks
    root = tmp_path / "c"
    cache = BuildCache(root)
    entry = cache.entry("kahraman_singh", key)
    with cache.locked(entry), cache.staging(entry) as st:
        (st / "gs_model.c").write_text("half written")
        os.rename(st, tmp_path / "away")
    leftover = root / st.name
    os.rename(tmp_path / "away", leftover)  # the builder was killed: its folder stayed
    renamed = Path(shutil.copytree(leftover, root / f".tmp-{entry.name}-renamed"))  # its marker, another name
    assert cache.clear() == []
    assert not leftover.exists() and (renamed / "gs_model.c").is_file()
    assert sorted(p.name for p in root.iterdir()) == [renamed.name]


# ------------------------------------------------------------------ item 4: the driver object
def _seed_driver(tmp_path: Path) -> Path:
    """A private driver cache holding a copy of the user's driver object (and its signature)."""
    name = _driver_name()
    src = engine_build.driver_cache_dir(tmp_path / "unused")
    engine_build.driver_object(src)  # made if missing
    drv = tmp_path / "driver"
    drv.mkdir()
    for f in src.glob(name + "*"):
        if not f.name.endswith(".lock"):
            shutil.copy2(f, drv / f.name)
    return drv / name


def test_truncated_driver_object_is_rebuilt(tmp_path, monkeypatch):
    # before: the object was used because it existed: every new build failed at link time
    obj = _seed_driver(tmp_path)
    size = obj.stat().st_size
    os.truncate(obj, size // 2)
    monkeypatch.setenv("GEARSYM_DRIVER_CACHE", str(obj.parent))
    gen = gearsym.load_scene(KS_SCENE).generate(generated_dir=tmp_path / "new")
    assert not gen.cached and obj.stat().st_size == size and obj.read_bytes()[:4] == b"\x7fELF"
    traj = gearsym.load_scene(KS_SCENE).compile(generated_dir=tmp_path / "new").simulate(periods=1)
    assert traj.y.size > 0 and all(map(math.isfinite, traj.y.ravel()))


def test_force_rebuilds_a_truncated_driver_object(tmp_path, ks, monkeypatch, capsys):
    # before: `gearsym compile --force` kept the truncated object and failed at link time again
    build, key = ks
    obj = _seed_driver(tmp_path)
    os.truncate(obj, 1000)
    monkeypatch.setenv("GEARSYM_DRIVER_CACHE", str(obj.parent))
    monkeypatch.setenv("GEARSYM_GENERATED", str(tmp_path / "c"))
    _copy(build, tmp_path / "c")
    assert main(["compile", str(KS_SCENE), "--force", "--json"]) == 0, capsys.readouterr().err
    assert json.loads(capsys.readouterr().out)["cached"] is False
    assert obj.stat().st_size > 1000 and obj.read_bytes()[:4] == b"\x7fELF"
