"""The SUNDIALS libraries an exported program carries with it (``lib/`` of the C project,
``binaries/linux64/`` of the FMU), with their licence.

gearsym links the SUNDIALS 7 shared libraries of the scikit-sundae wheel
(``scikit_sundae.libs/libsundials_*.so``, see :func:`gearsym.engine.build.find_sundials_libs`).
An exported program that named them by their path in the exporting environment would stop
working when that environment goes (a deleted virtual environment, another machine).  So
the export copies them: the six libraries the driver links (core, nvecserial,
sunmatrixdense, sunlinsoldense, cvode, ida) and every library they need that lies in the
same folder (read from their ELF ``DT_NEEDED`` entries; for the wheels seen so far there is
none: they need only each other, ``libm`` and ``libc``).  Each copy is named by its
``SONAME`` (the name the dynamic loader looks for), and the program finds them through an
``$ORIGIN``-relative run path, so the folder can be moved.

SUNDIALS is distributed under the BSD 3-Clause licence, which allows redistribution in
binary form provided the copyright notice, the conditions and the disclaimer are
reproduced in the documentation: the copies travel with ``LICENSE-SUNDIALS`` and
``NOTICE-SUNDIALS`` (the SUNDIALS project's texts) and, when the wheel carries them, the
licence files of scikit-sundae (which built the libraries).
"""

from __future__ import annotations

import ctypes
import hashlib
import importlib.metadata
import re
import struct
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path

from ..engine.build import find_sundials_libs
from ..engine.errors import SundialsNotFoundError
from .model_info import ExportError

__all__ = ["SundialsBundle", "elf_dynamic", "sundials_bundle"]

_DT_NEEDED, _DT_STRTAB, _DT_SONAME = 1, 5, 14
_PT_LOAD, _PT_DYNAMIC = 1, 2
_SAFE_NAME = re.compile(r"lib[A-Za-z0-9_.+-]+\.so[A-Za-z0-9_.+-]*")


@dataclass(frozen=True)
class SundialsBundle:
    """SUNDIALS libraries and licence texts to ship with an exported program.

    Attributes
    ----------
    libs
        File name (the library's ``SONAME``) -> its bytes, in link order (the driver's six
        libraries first, core first; then the libraries they need from the same folder).
    linked
        The names of the six libraries the program links directly.
    notices
        File name -> text: the licences (``LICENSE-SUNDIALS``, ``NOTICE-SUNDIALS``,
        scikit-sundae's files) and a ``README.md`` naming the source and checksums.
    version
        SUNDIALS version the libraries report (``SUNDIALSGetVersion``), e.g. ``"7.5.0"``.
    source
        Where they were copied from (the wheel's library folder).
    """

    libs: dict[str, bytes]
    linked: tuple[str, ...]
    notices: dict[str, str] = field(default_factory=dict)
    version: str = ""
    source: str = ""

    def files(self) -> dict[str, str | bytes]:
        """Every file of the bundle: the libraries, then the notices."""
        return {**self.libs, **self.notices}


def elf_dynamic(data: bytes) -> tuple[str | None, list[str]]:
    """``(SONAME, [DT_NEEDED ...])`` of a 64-bit little-endian ELF shared library.

    Reads the program headers: the ``PT_DYNAMIC`` segment and the string table that its
    ``DT_STRTAB`` address points to (mapped to a file offset through the ``PT_LOAD``
    segments).

    Raises
    ------
    ValueError
        Not a 64-bit little-endian ELF file with a dynamic section.
    """
    if data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
        raise ValueError("not a 64-bit little-endian ELF file")
    phoff, = struct.unpack_from("<Q", data, 0x20)
    phentsize, phnum = struct.unpack_from("<HH", data, 0x36)
    loads, dyn = [], None
    for i in range(phnum):
        p_type, _, p_offset, p_vaddr, _, p_filesz, _, _ = struct.unpack_from("<IIQQQQQQ", data, phoff + i * phentsize)
        if p_type == _PT_LOAD:
            loads.append((p_vaddr, p_offset, p_filesz))
        elif p_type == _PT_DYNAMIC:
            dyn = (p_offset, p_filesz)
    if dyn is None:
        raise ValueError("no dynamic section")
    entries = []
    for off in range(dyn[0], dyn[0] + dyn[1], 16):
        tag, val = struct.unpack_from("<qQ", data, off)
        if tag == 0:
            break
        entries.append((tag, val))
    strtab = next((v for t, v in entries if t == _DT_STRTAB), None)
    base = next((off + strtab - va for va, off, sz in loads if strtab is not None and va <= strtab < va + sz), None)
    if base is None:
        raise ValueError("the string table is outside every loaded segment")

    def string(k: int) -> str:
        end = data.index(b"\0", base + k)
        return data[base + k:end].decode("utf-8", "replace")

    soname = next((string(v) for t, v in entries if t == _DT_SONAME), None)
    return soname, [string(v) for t, v in entries if t == _DT_NEEDED]


def _version(core: Path) -> str:
    try:
        lib = ctypes.CDLL(str(core), mode=ctypes.RTLD_LOCAL)
        buf = ctypes.create_string_buffer(64)
        fn = lib.SUNDIALSGetVersion
        fn.restype, fn.argtypes = ctypes.c_int, [ctypes.c_char_p, ctypes.c_int]
        return buf.value.decode() if fn(buf, 64) == 0 else ""
    except (OSError, AttributeError):
        return ""


def _template(name: str) -> str:
    return resources.files("gearsym.export").joinpath("templates", name).read_text(encoding="utf-8")


def _wheel_licences() -> dict[str, str]:
    """scikit-sundae's licence files (its ``LICENSE`` and the bundled-licences list), if any."""
    try:
        dist = importlib.metadata.distribution("scikit-sundae")
    except importlib.metadata.PackageNotFoundError:
        return {}
    out = {}
    for f in dist.files or ():
        name = Path(str(f)).name
        if "licen" in str(f).lower() and name.upper().startswith("LICENSE"):
            try:
                out[f"{name}-scikit-sundae"] = Path(str(f.locate())).read_text(encoding="utf-8")
            except (OSError, UnicodeDecodeError):
                continue
    return dict(sorted(out.items()))


def sundials_bundle(where: str = "`$ORIGIN/lib` (this folder beside it)") -> SundialsBundle:
    """Collect the wheel's SUNDIALS libraries (and their non-system dependencies) for shipping.

    Parameters
    ----------
    where
        How the program finds them (for the ``README.md`` of the bundle).

    Returns
    -------
    SundialsBundle

    Raises
    ------
    ExportError
        The libraries are missing (scikit-sundae not installed) or cannot be read.
    """
    try:
        sl = find_sundials_libs()
    except SundialsNotFoundError as exc:
        raise ExportError(f"cannot bundle the SUNDIALS libraries with the exported program: {exc}") from None
    by_soname: dict[str, Path] = {}
    for p in sorted(sl.libdir.iterdir()):
        if p.is_file() and ".so" in p.name:
            by_soname.setdefault(p.name, p)
    libs: dict[str, bytes] = {}
    linked: list[str] = []
    todo = [(p, True) for p in sl.libs]
    while todo:
        path, direct = todo.pop(0)
        try:
            data = path.read_bytes()
            soname, needed = elf_dynamic(data)
        except (OSError, ValueError) as exc:
            raise ExportError(f"cannot bundle the SUNDIALS library {path}: {exc}") from None
        name = soname or path.name
        if not _SAFE_NAME.fullmatch(name):  # it becomes a file name and a linker argument
            raise ExportError(f"cannot bundle the SUNDIALS library {path}: unexpected SONAME {name!r}")
        if direct:
            linked.append(name)
        if name in libs:
            continue
        libs[name] = data
        # a dependency in the same folder is shipped too; anything else is a system library
        todo += [(by_soname[n], False) for n in needed if n in by_soname and n not in libs]
    version = _version(sl.libs[0])
    sums = "\n".join(f"| `{n}` | {len(b)} | `{hashlib.sha256(b).hexdigest()}` |" for n, b in libs.items())
    readme = (f"# SUNDIALS libraries of this exported program\n\n"
              f"SUNDIALS {version or '(version not read)'}, copied at export from `{sl.libdir.name}` of the "
              f"scikit-sundae wheel (the libraries gearsym links).  The program finds them through its run path "
              f"{where}, so the folder can be moved.\n\n"
              "SUNDIALS is BSD-3-Clause licensed: see `LICENSE-SUNDIALS` and `NOTICE-SUNDIALS`; the wheel's own "
              "licence files are here too when it had them.\n\n"
              "| file | bytes | sha256 |\n|---|---|---|\n" + sums + "\n")
    notices = {"LICENSE-SUNDIALS": _template("sundials/LICENSE"), "NOTICE-SUNDIALS": _template("sundials/NOTICE"),
               **_wheel_licences(), "README.md": readme}
    return SundialsBundle(libs=libs, linked=tuple(linked), notices=notices, version=version, source=str(sl.libdir))
