"""Write-then-rename, so a failed run never leaves a partial or clobbered file.

:func:`atomic_write` writes a temporary file beside the target and renames
it over the target when the writing succeeds. Inside :func:`all_or_nothing`
the renames wait until the whole block succeeds, so a run that writes an
output and a preview leaves either both or neither.
"""
from __future__ import annotations

import contextlib
import contextvars
import os
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import IO

_PENDING: contextvars.ContextVar[list[tuple[str, Path]] | None] = contextvars.ContextVar("pending", default=None)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "wb") -> Iterator[IO]:
    target = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent or ".")
    try:
        text = "b" not in mode
        with os.fdopen(fd, mode, encoding="utf-8" if text else None, newline="\n" if text else None) as fh:
            yield fh
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp's 0600 is for the temporary file only
        pending = _PENDING.get()
        if pending is None:
            os.replace(tmp, target)
        else:
            pending.append((tmp, target))
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def all_or_nothing() -> Iterator[None]:
    """Every :func:`atomic_write` inside lands only if the whole block succeeds."""
    pending: list[tuple[str, Path]] = []
    token = _PENDING.set(pending)
    try:
        yield
    except BaseException:
        for tmp, _ in pending:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp)
        raise
    finally:
        _PENDING.reset(token)
    for tmp, target in pending:
        os.replace(tmp, target)


def check_writable(path: str | os.PathLike) -> None:
    """Raise OSError unless a file can be created beside ``path`` (a real probe: root passes access())."""
    folder = Path(path).parent if str(Path(path).parent) else Path(".")
    fd, probe = tempfile.mkstemp(prefix=".osm-expand-probe.", dir=folder)
    os.close(fd)
    os.unlink(probe)
