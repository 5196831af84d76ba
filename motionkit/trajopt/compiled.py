"""Per-knot functions compiled to C: CasADi generates the code, the system C compiler builds it.

The knot Hessian is about 440,000 scalar operations; CasADi's virtual machine evaluates it in
about 1.9 ms, compiled code (-O1) in 0.19 ms, and -O1 -march=native (the default on x86-64: fused
multiply-adds and vector registers of this CPU) about 40 % faster again at the same compile time.
Compiling takes a minute or two, once: the shared library is cached under the robot cache folder
by a hash of the functions (weights and eps are parameters, so every config of a robot reuses
it), the flags and, for -march=native, the CPU it was built on. MOTIONKIT_TRAJOPT_COMPILE sets
the flags (-O0 compiles in ~15 s and runs ~2.5x faster than the virtual machine); 0, or no C
compiler, keeps the functions in the virtual machine.
"""

from __future__ import annotations

import hashlib
import inspect
import json
import os
import platform
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import casadi as cs

from motionkit.robot.model import cache_dir

LOADED: list[Path] = []  # the libraries this process loaded, in order (a driver ships them)
# -march=native on x86-64, where GCC and Clang both take it; plain -O1 elsewhere
DEFAULT_FLAGS = "-O1 -march=native" if platform.machine() in ("x86_64", "AMD64") else "-O1"


def optimisation() -> list[str] | None:
    """The compiler's optimisation flags, or None: do not compile."""
    flags = os.environ.get("MOTIONKIT_TRAJOPT_COMPILE", DEFAULT_FLAGS)
    return None if flags == "0" else flags.split()


def cpu_identity() -> str:
    """What -march=native compiles for: the machine and, where Linux says, the CPU model and its
    feature flags (a library cached in a shared home folder must not run on another CPU)."""
    identity = platform.machine() + platform.processor()
    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        return identity
    wanted = ("model name", "flags")
    return identity + "".join(sorted({line for line in lines if line.startswith(wanted)}))


def compiler() -> str | None:
    return shutil.which(os.environ.get("CC", "cc")) or shutil.which("gcc")


def _source(functions: Sequence[cs.Function], name: str) -> str:
    generator = cs.CodeGenerator(f"{name}.c", {"with_header": False})
    for function in functions:
        generator.add(function)
    return generator.dump()


def _build(cc: str, flags: list[str], functions: Sequence[cs.Function], library: Path) -> None:
    with tempfile.TemporaryDirectory(dir=library.parent) as tmp:
        c_file, so_file = Path(tmp) / "functions.c", Path(tmp) / library.name
        c_file.write_text(_source(functions, "functions"))
        subprocess.run([cc, *flags, str(c_file), "-o", str(so_file)], check=True)
        names = [function.name() for function in functions]
        _names_file(library).write_text(json.dumps(names))
        os.replace(so_file, library)  # atomic: a concurrent process sees all or nothing


def _names_file(library: Path) -> Path:
    return library.with_suffix(".json")


def compile_groups(
    bases: Sequence[cs.Function],
    derive: Callable[[cs.Function], Sequence[cs.Function]],
    log: Callable[[str], None] | None = None,
) -> list[list[cs.Function]]:
    """For each base function, the group [base, *derive(base)] as one compiled library (groups
    build in parallel), or uncompiled when no compiler is available. A library is keyed by the
    base function's expression graph, the code of `derive`, CasADi's version, the flags and for
    -march=native the CPU, so a cached one is loaded without building the derivatives or their
    source (~3 s)."""
    cc, optimise = compiler(), optimisation()
    if cc is None or optimise is None:
        return [[base, *derive(base)] for base in bases]
    flags = [*optimise, "-fPIC", "-shared"]
    folder = cache_dir() / "trajopt_compiled"
    folder.mkdir(parents=True, exist_ok=True)
    recipe = inspect.getsource(derive) + cs.__version__ + " ".join(flags)
    if any(flag.startswith("-march=native") for flag in flags):
        recipe += cpu_identity()

    def key(base: cs.Function) -> str:
        return hashlib.sha256((base.serialize() + recipe).encode()).hexdigest()[:16]

    libraries = [folder / f"{base.name()}_{key(base)}.so" for base in bases]
    missing = [
        ([base, *derive(base)], library)
        for base, library in zip(bases, libraries, strict=True)
        if not library.exists()
    ]
    if missing:
        if log:
            names = ", ".join(library.name for _, library in missing)
            log(f"compiling the problem's derivatives to C, once per robot (1-2 min): {names}")
        with ThreadPoolExecutor(max_workers=len(missing)) as pool:
            list(pool.map(lambda item: _build(cc, flags, *item), missing))
    LOADED.extend(libraries)
    return [
        # finite differences only so that CasADi's wrapper can build (never call) derivatives
        [
            cs.external(name, str(library), {"enable_fd": True})
            for name in json.loads(_names_file(library).read_text())
        ]
        for library in libraries
    ]


def export_libraries(libraries: Sequence[Path]) -> dict[str, bytes]:
    """The files of compiled `libraries` (each one's function names, then the library), for a
    worker whose cache does not hold them (`install_libraries`)."""
    files = {}
    for library in dict.fromkeys(libraries):
        for path in (_names_file(library), library):
            files[path.name] = path.read_bytes()
    return files


def install_libraries(files: dict[str, bytes]) -> None:
    """Put the exported library files this process's cache lacks into it (each atomically, the
    names before their library, so that a library found is whole and usable)."""
    if not files:
        return
    folder = cache_dir() / "trajopt_compiled"
    folder.mkdir(parents=True, exist_ok=True)
    for name, data in files.items():
        path = folder / name
        if path.exists():
            continue
        with tempfile.NamedTemporaryFile(dir=folder, delete=False) as stream:
            stream.write(data)
        os.chmod(stream.name, 0o755 if path.suffix == ".so" else 0o644)
        os.replace(stream.name, path)
