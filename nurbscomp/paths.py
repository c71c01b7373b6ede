"""Files on disk: outputs written whole or not at all, never over an input,
and containers read from a path.

An output is written to a temporary file in the target folder and renamed into
place only when complete, so a failure or an interrupt leaves nothing behind.
Every stage that writes a file (``pipeline``, ``passthrough``, ``batch``) goes
through :func:`atomic_output`.
"""

from __future__ import annotations

import contextlib
import os
import secrets
import signal
import stat
from collections.abc import Iterator
from pathlib import Path

from . import container, signals
from .errors import InputError, OutputError

#: Longest file name a temporary name's stem keeps, in bytes: the name
#: ``.STEM.XXXXXXXX.tmp`` then fits the 255 bytes of common file systems.
_TMP_STEM_BYTES = 200


def _os_message(e: OSError) -> str:
    return e.strerror or str(e)


def check_output(dst: Path, force: bool, inputs: tuple[Path, ...] = ()) -> None:
    """Refuse an output that may not be written, before any work is done.

    Raises
    ------
    OutputError
        ``dst`` is one of ``inputs`` (even with ``force``), exists and ``force``
        is not set, is a folder, or cannot be looked at (the OS's message); or
        it is not a regular file (a symbolic link, even a dangling one, a FIFO,
        a device, a socket), which is never replaced, even with ``force``.
    """
    try:
        if not dst.exists():
            if dst.is_symlink():
                raise OutputError(f"{dst} is a symbolic link; it is never replaced")
            return
        for src in inputs:
            if src.exists() and os.path.samefile(src, dst):
                raise OutputError(f"{dst} is the input file; it is never overwritten")
        if dst.is_dir():
            raise OutputError(f"{dst} is a directory")
        kind = _not_regular(dst)
        if kind:
            raise OutputError(f"{dst} is {kind}, not a regular file; it is never replaced")
    except OSError as e:
        raise OutputError(f"cannot write {dst}: {_os_message(e)}") from None
    if not force:
        raise OutputError(f"{dst} already exists (use --force to overwrite)")


def _not_regular(path: Path) -> str:
    """What ``path`` is if it is not a regular file (``"a symbolic link"``,
    ``"a FIFO"`` …), else ``""``; the link itself is looked at, not its target."""
    mode = os.lstat(path).st_mode
    if stat.S_ISREG(mode):
        return ""
    for test, kind in (
        (stat.S_ISLNK, "a symbolic link"),
        (stat.S_ISFIFO, "a FIFO"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
    ):
        if test(mode):
            return kind
    return "a special file"


def _tmp_prefix(name: str) -> str:
    """``.NAME.``, NAME cut to ``_TMP_STEM_BYTES`` bytes (:func:`_make_temporary`
    adds the unique part)."""
    while len(os.fsencode(name)) > _TMP_STEM_BYTES:  # whole characters only
        name = name[: -1 - (len(os.fsencode(name)) - _TMP_STEM_BYTES) // 4]
    return f".{name}."


@contextlib.contextmanager
def atomic_output(dst: Path, force: bool, inputs: tuple[Path, ...] = ()) -> Iterator[Path]:
    """Yield a temporary path beside ``dst``; rename it to ``dst`` on success.

    The temporary name is ``.NAME.XXXXXXXX.tmp`` (NAME shortened so that it
    fits 255 bytes); it is removed on any failure or interrupt (the CLI turns
    SIGTERM and SIGHUP into interrupts), and is not renamed once a stop signal
    has come (``signals.check``), even one whose interrupt was lost.

    Raises
    ------
    OutputError
        ``dst`` is one of ``inputs``, exists and ``force`` is not set, its
        folder does not exist, or the OS refuses a write (its message).
    """
    check_output(dst, force, inputs)
    folder = dst.parent if str(dst.parent) else Path(".")
    if not folder.is_dir():
        raise OutputError(f"output folder {folder} does not exist")
    # no interrupt between making the file and the try that removes it: the
    # signals the CLI turns into interrupts wait until the try is entered.
    # The mask holds this thread only: a signal another thread takes still
    # runs its handler here, so the name is also listed before the file is
    # made, and the CLI removes what is listed on its way out (remove_leftovers)
    held = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}
    old_mask = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        tmp = _make_temporary(folder, _tmp_prefix(dst.name))
    except OSError as e:
        signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)
        raise OutputError(f"cannot write in {folder}: {_os_message(e)}") from None
    try:
        signal.pthread_sigmask(signal.SIG_SETMASK, old_mask)
        yield Path(tmp)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600; outputs get the usual mode
        check_output(dst, force, inputs)  # the input may have been linked there meanwhile
        signals.check()  # a stop signal that came, even one Python swallowed: no output
        os.replace(tmp, dst)
    except OSError as e:
        raise OutputError(f"cannot write {dst}: {_os_message(e)}") from None
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        _LIVE.discard(tmp)


#: Temporary outputs that exist or are being made (:func:`atomic_output`).
_LIVE: set[str] = set()


def _make_temporary(folder: Path, prefix: str) -> str:
    """Make an empty file ``folder/prefix<random>.tmp`` (mode 0600), listed in
    ``_LIVE`` before it exists; its name."""
    for _ in range(100):
        tmp = str(folder / f"{prefix}{secrets.token_hex(4)}.tmp")
        _LIVE.add(tmp)
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600))
            return tmp
        except FileExistsError:
            _LIVE.discard(tmp)
        except BaseException:
            # an interrupt can come once the file is made (a stop signal that
            # another thread took runs its handler here, at any bytecode): the
            # file is ours then, removed here, else by remove_leftovers
            with contextlib.suppress(OSError):
                os.unlink(tmp)
            _LIVE.discard(tmp)
            raise
    raise FileExistsError(f"no free temporary name in {folder}")


def remove_leftovers() -> None:
    """Remove the temporary outputs still listed: an interrupt that came
    between a file's making and the ``try`` that removes it (a signal taken
    by another thread is not held by this thread's mask)."""
    for tmp in list(_LIVE):
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        _LIVE.discard(tmp)


def read_input(path: Path) -> bytes:
    """The bytes of an input file.

    Raises
    ------
    InputError
        The file is missing, is a folder, or cannot be read.
    """
    if not path.exists():
        raise InputError("no such file")
    if path.is_dir():
        raise InputError("is a directory")
    try:
        return path.read_bytes()
    except OSError as e:
        raise InputError(e.strerror or str(e)) from None


def read_container(path: Path) -> container.Container:
    """Read and check a ``.nzc`` file.

    Raises
    ------
    InputError
        The file is missing or is a folder.
    FormatError
        The bytes are not a valid container.
    """
    return container.unpack(read_input(path))
