"""Atomic file output: a failed or interrupted run leaves the previous good output in place."""

from __future__ import annotations

import json
import math
import os
import shutil
import tempfile
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, Iterator


def read_toml(path: str | Path, what: str, error: type[Exception] = ValueError) -> dict:
    """Parse the TOML file `path` (a `what` file: "design", "scene", "sequence" ...).

    A missing or malformed file raises `error` with one line that names the file and the problem.
    """
    try:
        import tomllib
    except ModuleNotFoundError:  # pragma: no cover - Python 3.10
        import tomli as tomllib  # type: ignore[no-redef]
    path = Path(path)
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise error(f"{what} file {path} does not exist") from None
    except IsADirectoryError:
        raise error(f"{what} file {path} is a folder; give a TOML file") from None
    except UnicodeDecodeError as err:
        raise error(f"{what} file {path}: not UTF-8 text (byte {err.start}); save it as UTF-8 TOML") from None
    except tomllib.TOMLDecodeError as err:
        raise error(f"{what} file {path}: not valid TOML: {err}") from None


def atomic_write_bytes(path: str | Path, data: bytes) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; give the file normal permissions
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
    return path


def atomic_write_text(path: str | Path, text: str) -> Path:
    return atomic_write_bytes(path, text.encode())


def _finite(obj: Any, where: str = "") -> Any:
    """Refuse NaN/inf anywhere in a JSON document, naming where it is."""
    if isinstance(obj, float) and not math.isfinite(obj):
        raise ValueError(f"non-finite number {obj} at {where or '<root>'}")
    if isinstance(obj, dict):
        return {k: _finite(v, f"{where}.{k}" if where else str(k)) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_finite(v, f"{where}[{i}]") for i, v in enumerate(obj)]
    return obj


def atomic_write_json(path: str | Path, obj: Any) -> Path:
    """Write JSON atomically; NaN or inf anywhere raises ValueError naming the key."""
    return atomic_write_text(path, json.dumps(_finite(obj), indent=2, allow_nan=False) + "\n")


def _staging_prefix(final: Path) -> str:
    return f".{final.name}.tmp-"


@contextmanager
def staging_dir(final: str | Path) -> Iterator[Path]:
    """A temporary folder beside `final` (same file system, so renames are atomic); removed afterwards."""
    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=_staging_prefix(final), dir=final.parent))
    try:
        yield tmp
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


def drop_stale_staging(final: str | Path) -> None:
    """Remove the staging folders a killed writer of `final` left beside it (a SIGKILL skips
    staging_dir's cleanup); only one writer per output folder may run at a time."""
    final = Path(final)
    for stale in final.parent.glob(_staging_prefix(final) + "*"):
        shutil.rmtree(stale, ignore_errors=True)


def publish(staged: Path, final: Path, names: list[str], stale: list[str] = (),
            after_each: Callable[[str], None] | None = None) -> None:
    """Move `names` from `staged` into `final` one atomic rename each, then drop `stale` files.

    Callers put the index file (e.g. manifest.json) last, so a reader never sees an index that
    points to files not yet in place; a process killed part-way leaves the old index, whose file
    hashes then disagree with the files already replaced (see whisker.cad.buildkey.up_to_date).
    `after_each(name)` runs after every rename (progress, or a test that kills the build there).
    """
    final.mkdir(parents=True, exist_ok=True)
    for name in names:
        (final / name).parent.mkdir(parents=True, exist_ok=True)
        os.replace(staged / name, final / name)
        if after_each:
            after_each(name)
    for name in stale:
        if name not in names:
            (final / name).unlink(missing_ok=True)


class OutputBusy(OSError):
    """Another process is writing the same output."""


@contextmanager
def output_lock(final: str | Path) -> Iterator[Path]:
    """Hold an exclusive lock on the output `final` (a file or folder) for the duration of a run.

    The lock is ``.NAME.lock`` beside it, held with fcntl.flock (the kernel drops it when the
    process dies, so a crash leaves no stale lock). A second writer raises `OutputBusy` at once
    instead of racing the first to the last rename."""
    import fcntl

    final = Path(final)
    final.parent.mkdir(parents=True, exist_ok=True)
    lock = final.parent / f".{final.name}.lock"
    fd = os.open(lock, os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            try:
                other = os.read(fd, 32).decode(errors="replace").strip() or "?"
            except OSError:
                other = "?"
            raise OutputBusy(f"{final} is being written by another run (pid {other}); wait for it or give "
                             f"another --out") from None
        os.ftruncate(fd, 0)
        os.write(fd, str(os.getpid()).encode())
        try:
            yield final
        finally:
            lock.unlink(missing_ok=True)
    finally:
        os.close(fd)
