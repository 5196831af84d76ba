"""Download CMU Graphics Lab motion-capture clips (ASF skeleton + AMC motion) into the cache.

Files come over HTTPS (a redirect to plain HTTP is refused). Each is streamed to a temporary file
beside its target, within a size bound; a clip's AMC and ASF are renamed into the cache only when
both parse (the motion against its skeleton), so the cache never holds a partial or wrong file,
also when the download fails or is interrupted.
"""

from __future__ import annotations

import contextlib
import http.client
import re
import sys
import urllib.error
import urllib.request
from collections.abc import Iterable
from pathlib import Path
from typing import IO, NamedTuple, Protocol

from motionkit import __version__
from motionkit.core.errors import MocapError
from motionkit.files.outputs import atomic_output
from motionkit.robot.model import cache_dir
from motionkit.runtime.progress import LineProgress

CMU_BASE_URL = "https://mocap.cs.cmu.edu"
_CHUNK = 64 * 1024
MAX_BYTES = {".asf": 1 << 20, ".amc": 64 << 20}  # CMU's: ASF ~10 KB, AMC up to ~20 MB
_CLIP_ID = re.compile(r"(\d{1,3})_(\d{1,2})")
_FRAME_LINE = re.compile(rb"^[ \t]*\d+[ \t]*\r?$", re.MULTILINE)
_AMC_HEADERS = (b":degrees", b":radians", b":fully-specified")
_ASF_SECTIONS = (b":bonedata", b":hierarchy")


class FetchError(MocapError):
    """A CMU clip id is malformed, or a clip could not be downloaded or is not what it should be."""


class ClipId(NamedTuple):
    """A CMU clip: subject and trial numbers; `str()` gives the canonical "02_01" form."""

    subject: int
    trial: int

    @property
    def subject_code(self) -> str:
        return f"{self.subject:02d}"

    def __str__(self) -> str:
        return f"{self.subject:02d}_{self.trial:02d}"


def parse_clip_id(text: str) -> ClipId:
    """Parse "02_01", "2_1" or "143_05" (subject_trial) into a `ClipId`."""
    match = _CLIP_ID.fullmatch(text.strip())
    if match is None or int(match[1]) == 0 or int(match[2]) == 0:
        raise FetchError(
            f"bad CMU clip id {text!r}: expected SUBJECT_TRIAL with positive numbers, "
            'e.g. "02_01" or "143_05"'
        )
    return ClipId(int(match[1]), int(match[2]))


def clip_cache_dir() -> Path:
    """Where downloaded CMU clips live: <motionkit cache>/mocap/cmu/<SS>/."""
    return cache_dir() / "mocap" / "cmu"


def fetch_clips(
    clip_ids: Iterable[str],
    cache: Path | None = None,
    base_url: str = CMU_BASE_URL,
    progress: bool = True,
    timeout: float = 30.0,
) -> list[tuple[Path, Path]]:
    """Make sure each clip's AMC and its subject's ASF are in the cache; return (amc, asf) paths.

    Files already in the cache and valid are not downloaded again. Raises `FetchError` naming the
    clip and URL when a file is missing on the server, wrong, truncated or unreachable.
    """
    if isinstance(clip_ids, str):  # one id, not its characters
        clip_ids = [clip_ids]
    clips = [parse_clip_id(text) for text in clip_ids]  # all ids checked before any download
    root = clip_cache_dir() if cache is None else Path(cache)
    base = base_url.rstrip("/")
    paths = []
    for clip in clips:
        folder = root / clip.subject_code
        remote = f"{base}/subjects/{clip.subject_code}"
        amc = folder / f"{clip}.amc"
        asf = folder / f"{clip.subject_code}.asf"
        missing = [path for path in (amc, asf) if not _is_valid_file(path)]
        if missing:
            _download_clip(missing, amc, asf, remote, str(clip), progress, timeout)
        paths.append((amc, asf))
    return paths


def _download_clip(
    missing: list[Path],
    amc: Path,
    asf: Path,
    remote: str,
    clip: str,
    progress: bool,
    timeout: float,
) -> None:
    """Download the `missing` files of a clip (AMC first: a wrong trial number then costs no
    ASF download) and move them into the cache once the motion parses with its skeleton."""
    made_folder = not amc.parent.exists()
    try:
        with contextlib.ExitStack() as renames:  # each temporary renamed as the stack closes
            local = {}
            for path in missing:
                stream = renames.enter_context(atomic_output(path))
                _download(f"{remote}/{path.name}", path.suffix, stream, clip, progress, timeout)
                local[path] = Path(stream.name)
            _check_parses(local.get(amc, amc), local.get(asf, asf), f"clip {clip}: {remote}")
    except BaseException:
        if made_folder:  # leave no empty subject folder behind
            with contextlib.suppress(OSError):
                amc.parent.rmdir()
        raise


def _check_parses(amc: Path, asf: Path, where: str) -> None:
    from motionkit.mocap.asf_amc import read_amc, read_asf

    try:
        read_amc(amc, read_asf(asf))
    except MocapError as exc:
        raise FetchError(f"{where}: the files do not parse as an ASF/AMC clip: {exc}") from exc


def _is_valid_file(path: Path) -> bool:
    try:
        return _content_problem(path.suffix, path.read_bytes()) is None
    except OSError:
        return False


def _content_problem(suffix: str, data: bytes) -> str | None:
    """Why `data` is not a plausible ASF/AMC file, or None when it is."""
    head = data[:512].lstrip().lower()
    if head.startswith((b"<!doctype html", b"<html")):
        return "got an HTML page instead of the file (the clip probably does not exist)"
    lowered = data.lower()
    if suffix == ".asf":
        missing = [s.decode() for s in _ASF_SECTIONS if s not in lowered]
        if missing:
            return f"not an ASF skeleton: no {' or '.join(missing)} section"
    elif not any(h in lowered for h in _AMC_HEADERS):
        return "not an AMC motion: no :DEGREES, :RADIANS or :FULLY-SPECIFIED header"
    elif _FRAME_LINE.search(data) is None:
        return "not an AMC motion: no frame-number line"
    return None


def _download(
    url: str, suffix: str, stream: IO[bytes], clip: str, progress: bool, timeout: float
) -> None:
    """Stream `url` into `stream` and check what came; FetchError naming the URL when wrong."""
    problem = _stream(url, stream, clip, progress, timeout, MAX_BYTES[suffix])
    if problem is None:
        stream.flush()
        problem = _content_problem(suffix, Path(stream.name).read_bytes())
    if problem is not None:
        raise FetchError(f"clip {clip}: {url}: {problem}")


class _NoDowngrade(urllib.request.HTTPRedirectHandler):
    """Follow redirects, except from HTTPS to plain HTTP."""

    def redirect_request(
        self,
        req: urllib.request.Request,
        fp: IO[bytes],
        code: int,
        msg: str,
        headers: http.client.HTTPMessage,
        newurl: str,
    ) -> urllib.request.Request | None:
        if req.full_url.startswith("https:") and not newurl.startswith("https:"):
            refused = "redirect to plain HTTP refused"
            raise urllib.error.HTTPError(newurl, code, refused, headers, fp)
        return super().redirect_request(req, fp, code, msg, headers, newurl)


_OPENER = urllib.request.build_opener(_NoDowngrade)


def _stream(
    url: str, stream: IO[bytes], clip: str, progress: bool, timeout: float, limit: int
) -> str | None:
    """Copy the body of `url` (at most `limit` bytes) into `stream`; return what was wrong with
    the response, or None."""
    request = urllib.request.Request(url, headers={"User-Agent": f"motionkit/{__version__}"})
    try:
        response = _OPENER.open(request, timeout=timeout)
    except urllib.error.HTTPError as error:
        error.close()
        return f"HTTP {error.code} {error.reason}"
    except (urllib.error.URLError, OSError, http.client.HTTPException) as error:
        reason = getattr(error, "reason", error)
        if isinstance(reason, TimeoutError):
            reason = f"no answer within {timeout:g} s"
        raise FetchError(f"clip {clip}: cannot reach {url}: {reason}") from error
    with response:
        if response.status != 200:
            return f"HTTP {response.status} {response.reason} (expected 200)"
        if "html" in response.headers.get("Content-Type", "").lower():
            return "got an HTML page instead of the file (the clip probably does not exist)"
        length = response.headers.get("Content-Length")
        total = int(length) if length and length.isdigit() else None
        if total is not None and total > limit:
            return f"{total} bytes announced, more than the {limit} a clip file may have"
        received = 0
        bar = _progress_bar(url.rsplit("/", 1)[-1], total) if progress else None
        try:
            while chunk := response.read(_CHUNK):
                stream.write(chunk)
                received += len(chunk)
                if received > limit:
                    return f"more than the {limit} bytes a clip file may have"
                if bar is not None:
                    bar.update(len(chunk))
        except (OSError, http.client.HTTPException) as error:
            reason = str(error) or type(error).__name__
            return f"download broke off after {received} bytes ({reason})"
        finally:
            if bar is not None:
                bar.close()
    if total is not None and received != total:
        return f"incomplete download: received {received} of {total} bytes"
    return None


class _Bar(Protocol):
    def update(self, n: int) -> object: ...
    def close(self) -> None: ...


class _LineBar:
    """Fallback progress bar (motionkit.runtime.progress: a rewritten line on a terminal)."""

    def __init__(self, name: str, total: int | None) -> None:
        self.total, self.received = total, 0
        self.line = LineProgress(name)

    def update(self, n: int) -> None:
        self.received += n
        done = f"{self.received / 1024:.1f}"
        if self.total:
            text = f"{done}/{self.total / 1024:.1f} KiB ({100 * self.received // self.total}%)"
        else:
            text = f"{done} KiB"
        self.line.show(text)

    def close(self) -> None:
        self.line.close()


def _progress_bar(name: str, total: int | None) -> _Bar:
    if not sys.stderr.isatty():  # a log: plain lines (tqdm would write carriage returns)
        return _LineBar(name, total)
    try:
        from tqdm import tqdm
    except ImportError:  # tqdm is optional
        return _LineBar(name, total)
    return tqdm(  # same update/close interface
        desc=name, total=total, unit="B", unit_scale=True, unit_divisor=1024, file=sys.stderr
    )
