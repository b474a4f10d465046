"""Write-then-rename, so a failed run never leaves a partial or clobbered file.

:func:`atomic_write` writes a temporary file beside the target and renames
it over the target when the writing succeeds. Inside :func:`all_or_nothing`
the renames wait until the whole block succeeds, so a run that writes an
output and a preview leaves either both or neither.
"""
from __future__ import annotations

import contextlib
import contextvars
import errno
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


def _temp_prefix(target: Path) -> str:
    """The temporary file's name prefix: the target's name, shortened so the whole name fits NAME_MAX.

    mkstemp adds 8 random characters and ``.tmp``; a 245-character output
    name would otherwise fail only after all the work (ENAMETOOLONG).
    """
    room = _name_max(target.parent) - 1 - 1 - 8 - len(".tmp")  # leading dot, separating dot, random part
    name = target.name
    while len(os.fsencode(name)) > room:
        name = name[:-1]
    return f".{name}."


def _name_max(folder: Path) -> int:
    try:
        return os.pathconf(folder if str(folder) else ".", "PC_NAME_MAX")
    except (OSError, ValueError):
        return 255


@contextlib.contextmanager
def atomic_write(path: str | os.PathLike, mode: str = "wb") -> Iterator[IO]:
    """Write ``path`` through a temporary file beside it; signals are held until the file is complete.

    (:func:`osm_expand.interrupts.deferred`: an interrupt raised inside a
    writer's C callbacks could be lost.) On any failure, or an interrupt,
    the temporary file is removed and ``path`` is left as it was.
    """
    from osm_expand.interrupts import deferred

    target = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=_temp_prefix(target), suffix=".tmp", dir=target.parent or ".")
    try:
        with deferred():
            # errors="replace": a lone surrogate (a name read from "\ud800" in JSON) cannot be UTF-8
            binary = "b" in mode
            with os.fdopen(fd, mode, encoding=None if binary else "utf-8", newline=None if binary else "\n",
                           errors=None if binary else "replace") as fh:
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
    from osm_expand.interrupts import deferred

    with deferred():  # all the renames, or (an error) none of the files left behind
        try:
            for k, (tmp, target) in enumerate(pending):  # noqa: B007 (k is read in the except below)
                os.replace(tmp, target)
        except BaseException:
            for tmp, _ in pending[k:]:
                with contextlib.suppress(FileNotFoundError):
                    os.unlink(tmp)
            raise


def check_writable(path: str | os.PathLike) -> None:
    """Raise OSError unless a file can be created beside ``path`` (a real probe: root passes access()),
    and unless its name fits the file system (ENAMETOOLONG)."""
    target = Path(path)
    folder = target.parent if str(target.parent) else Path(".")
    fd, probe = tempfile.mkstemp(prefix=".osm-expand-probe.", dir=folder)
    os.close(fd)
    os.unlink(probe)
    if len(os.fsencode(target.name)) > _name_max(folder):
        raise OSError(errno.ENAMETOOLONG, os.strerror(errno.ENAMETOOLONG), str(target))
