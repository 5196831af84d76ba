"""Reading a TOML input file with errors of the caller's family."""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from motionkit.errors import MotionkitError


def read_toml(path: Path, what: str, error: type[MotionkitError]) -> dict[str, Any]:
    """The parsed file, or `error` naming the file and what is wrong with it."""
    try:
        return tomllib.loads(Path(path).read_text())
    except OSError as exc:
        raise error(f"{path}: cannot read {what} ({exc.strerror})") from exc
    except tomllib.TOMLDecodeError as exc:
        raise error(f"{path}: not valid TOML ({exc})") from exc
