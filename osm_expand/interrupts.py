"""Ctrl-C, SIGTERM and SIGHUP: one exception, the same clean-up, exit 128 + the signal's number.

Python turns only SIGINT into an exception; SIGTERM (``kill``, a batch
system's time limit) and SIGHUP (a closed terminal) kill the process where
it stands, leaving the output's temporary file and the clip's node store
(gigabytes on a country file) behind. :func:`signals_raise` makes all three
raise :class:`Interrupted`, a :class:`KeyboardInterrupt`, so every
``with``/``finally`` that cleans up after Ctrl-C cleans up after them too.

:func:`deferred` holds the signals back while a file is written: raised
inside a C extension's callback (lxml's writer calls the file's ``write``,
matplotlib its own), an exception can be lost or turned into another (issue
21 saw an interrupt end in exit 0 once and in a TypeError once). There the
signal is noted and raised when the block ends, before the file is renamed
into place, so the temporary file is removed and the target is untouched.
A signal whose exception was swallowed anywhere else is remembered
(:func:`received`): the next file is not renamed into place, and the run
ends interrupted all the same.

Signal handlers are process state: only the command line installs them,
and only from the main thread (a batch worker's thread leaves them alone).
"""
from __future__ import annotations

import contextlib
import signal
import threading
from collections.abc import Iterator

#: The signals treated as "stop now, clean up": Ctrl-C, kill, a closed terminal.
SIGNALS = tuple(s for s in (signal.SIGINT, signal.SIGTERM, getattr(signal, "SIGHUP", None)) if s is not None)


class Interrupted(KeyboardInterrupt):
    """The run was stopped by a signal; ``exit_code`` is 128 + its number (130, 143, 129).

    A subclass, not KeyboardInterrupt itself: CPython re-kills the process
    with SIGINT at exit when a C extension saw a bare KeyboardInterrupt
    (exit -2 instead of 130), and it tests the exact type.
    """

    def __init__(self, signum: int = signal.SIGINT):
        super().__init__(signal.Signals(signum).name)
        self.signum = int(signum)
        self.exit_code = 128 + int(signum)


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


#: Signals raised as :class:`Interrupted` since :func:`signals_raise` began: an exception raised inside a C
#: extension's callback can be swallowed or turned into another, so the signal itself is remembered.
_RECEIVED: list[int] = []


def received() -> Interrupted | None:
    """The interrupt of a signal that came (even if some library swallowed its exception), or None."""
    return Interrupted(_RECEIVED[0]) if _RECEIVED else None


def _raise(signum: int, frame: object) -> None:
    _RECEIVED.append(signum)
    raise Interrupted(signum)


@contextlib.contextmanager
def signals_raise() -> Iterator[None]:
    """Inside the block SIGINT, SIGTERM and SIGHUP raise :class:`Interrupted`; the old handlers come back after.

    A signal whose handler is "ignore" (``nohup``) stays ignored.
    """
    if not _main_thread():
        yield
        return
    old = {s: signal.getsignal(s) for s in SIGNALS}
    _RECEIVED.clear()
    for s, handler in old.items():
        if handler is not signal.SIG_IGN:
            signal.signal(s, _raise)
    try:
        yield
    finally:
        _restore(old)
        _RECEIVED.clear()


def _restore(handlers: dict) -> None:
    """Put the signal handlers back as they were (a handler Python did not install reads as None: default)."""
    for s, handler in handlers.items():
        signal.signal(s, handler if handler is not None else signal.SIG_DFL)


@contextlib.contextmanager
def deferred() -> Iterator[None]:
    """Hold the signals back inside the block; the first one noted is raised when it ends.

    Nested blocks hold them until the outermost ends. The exception the
    block raises itself wins over a noted signal. A signal that came
    earlier but whose exception a library swallowed (:func:`received`) is
    raised here too, so the file it guards does not land.
    """
    if not _main_thread():
        yield
        return
    old = {s: signal.getsignal(s) for s in SIGNALS}
    if any(getattr(h, "_deferring", False) for h in old.values()):  # an outer block holds them already
        yield
        return
    held = {s: h for s, h in old.items() if h is not signal.SIG_IGN}
    noted: list[int] = []
    note = _note_into(noted)
    for s in held:
        signal.signal(s, note)
    try:
        yield
    finally:
        _restore(held)
    if noted:
        handler = old[noted[0]]
        if callable(handler):
            handler(noted[0], None)  # the handler that was in place: ours raises, Python's raises KeyboardInterrupt
        raise Interrupted(noted[0])  # SIG_DFL: stop all the same, cleanly
    swallowed = received()
    if swallowed is not None:  # an earlier signal's exception was lost in a library: nothing lands
        raise swallowed


def _note_into(noted: list[int]):
    def note(signum: int, frame: object) -> None:
        noted.append(signum)

    note._deferring = True  # type: ignore[attr-defined]
    return note
