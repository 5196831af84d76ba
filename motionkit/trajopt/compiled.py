"""Per-knot functions compiled to C: CasADi generates the code, the system C compiler builds it.

The knot Hessian is about 440,000 scalar operations; CasADi's virtual machine evaluates it in
about 1.9 ms, compiled code (-O1) in 0.19 ms. Compiling takes a minute or two, once: the shared
library is cached under the robot cache folder by the hash of the generated source (weights and
eps are parameters, so every config of a robot reuses it). MOTIONKIT_TRAJOPT_COMPILE picks the
optimisation flag (default -O1; -O0 compiles in ~15 s and runs ~2.5x faster than the virtual
machine); 0, or no C compiler, keeps the functions in the virtual machine.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import casadi as cs

from motionkit.robot.model import cache_dir


def optimisation() -> str | None:
    """The compiler's -O flag, or None: do not compile."""
    level = os.environ.get("MOTIONKIT_TRAJOPT_COMPILE", "-O1")
    return None if level == "0" else level


def compiler() -> str | None:
    return shutil.which(os.environ.get("CC", "cc")) or shutil.which("gcc")


def _source(functions: Sequence[cs.Function], name: str) -> str:
    generator = cs.CodeGenerator(f"{name}.c", {"with_header": False})
    for function in functions:
        generator.add(function)
    return generator.dump()


def _build(cc: str, flags: list[str], source: str, library: Path) -> None:
    with tempfile.TemporaryDirectory(dir=library.parent) as tmp:
        c_file, so_file = Path(tmp) / "functions.c", Path(tmp) / library.name
        c_file.write_text(source)
        subprocess.run([cc, *flags, str(c_file), "-o", str(so_file)], check=True)
        os.replace(so_file, library)  # atomic: a concurrent process sees all or nothing


def compile_groups(
    groups: Sequence[Sequence[cs.Function]], log: Callable[[str], None] | None = None
) -> list[list[cs.Function]]:
    """Each group of functions as one compiled library (groups build in parallel), or the
    functions unchanged when no compiler is available."""
    cc, level = compiler(), optimisation()
    if cc is None or level is None:
        return [list(group) for group in groups]
    flags = [level, "-fPIC", "-shared"]
    folder = cache_dir() / "trajopt_compiled"
    folder.mkdir(parents=True, exist_ok=True)
    libraries: list[Path] = []
    missing: list[tuple[str, Path]] = []
    for group in groups:
        source = _source(group, "functions")
        digest = hashlib.sha256((source + " ".join(flags)).encode()).hexdigest()[:16]
        library = folder / f"{group[0].name()}_{digest}.so"
        libraries.append(library)
        if not library.exists():
            missing.append((source, library))
    if missing:
        if log:
            names = ", ".join(lib.name for _, lib in missing)
            log(f"compiling the problem's derivatives to C, once per robot (1-2 min): {names}")
        with ThreadPoolExecutor(max_workers=len(missing)) as pool:
            list(pool.map(lambda item: _build(cc, flags, *item), missing))
    return [
        # finite differences only so that CasADi's wrapper can build (never call) derivatives
        [cs.external(function.name(), str(library), {"enable_fd": True}) for function in group]
        for group, library in zip(groups, libraries, strict=True)
    ]
