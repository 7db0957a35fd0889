"""Opening the files users name, never blocking and never accepting a special file.

A path a user passes (a scene, a CSV or MCAP output, the node's ``record_path``) may name a
FIFO, a device or a directory, or be swapped for one between a check and the open (a symlink
flipped from a file to a FIFO). Opening a FIFO blocks until the other end opens it,
``/dev/zero`` never ends and ``/dev/full`` fails every write, so these helpers open with
``O_NONBLOCK`` (an open never waits), check the *opened* descriptor with ``fstat`` (no window
between check and use), refuse anything but a regular file with :class:`NotRegularFileError`,
bound what they read, and truncate an output only once it is known to be a regular file.
Errors are :class:`OSError` subclasses whose message says what the path is and what was
expected. :func:`create_new_file` creates a file that must not exist yet (``O_EXCL``), so an
existing file is never truncated by it.

Where the package's own files are (the default scene) is :mod:`rigid_body_sim.package_data`.
"""

from __future__ import annotations

import errno
import fcntl
import io
import os
import stat
from pathlib import Path
from typing import BinaryIO

__all__ = ["NotRegularFileError", "FileTooLargeError", "file_kind", "open_for_reading", "read_regular_file",
           "open_for_writing", "check_writable_path", "same_file", "text_writer", "create_new_file"]


class NotRegularFileError(OSError):
    """The path is not a regular file (a FIFO, a device, a directory, a socket); nothing was read
    from or written to it."""


class FileTooLargeError(OSError):
    """A file to read is larger than the caller's bound; nothing past the bound was read."""


_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO"), (stat.S_ISCHR, "a character device"),
          (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket"), (stat.S_ISREG, "a regular file"))


def file_kind(mode: int) -> str:
    """What ``st_mode`` says a file is: ``"a regular file"``, ``"a FIFO"``, ``"a character device"``..."""
    for test, kind in _KINDS:
        if test(mode):
            return kind
    return "a special file"


def _not_regular(path: str | os.PathLike[str], mode: int, expected: str) -> NotRegularFileError:
    code = errno.EISDIR if stat.S_ISDIR(mode) else errno.EINVAL
    return NotRegularFileError(code, f"not a regular file ({file_kind(mode)}); expected {expected}", os.fspath(path))


def _blocking(fd: int) -> None:
    """Clear O_NONBLOCK again (it only served the open; regular files ignore it anyway)."""
    fcntl.fcntl(fd, fcntl.F_SETFL, fcntl.fcntl(fd, fcntl.F_GETFL) & ~os.O_NONBLOCK)


def open_for_reading(path: str | os.PathLike[str], *, expected: str = "a regular file") -> BinaryIO:
    """Open a regular file for reading (binary), never blocking and never accepting a special file.

    The open uses ``O_NONBLOCK`` (a FIFO would otherwise block until a writer comes) and the
    opened descriptor is checked with ``fstat``, so a path swapped between a caller's check and
    this open is caught too.

    Parameters
    ----------
    path : str or PathLike
    expected : str
        What the caller wanted, for the error message (e.g. ``"a YAML file"``).

    Raises
    ------
    NotRegularFileError
        If the opened file is a FIFO, device, directory or socket (the descriptor is closed).
    OSError
        If it cannot be opened (missing, no permission...).
    """
    fd = os.open(path, os.O_RDONLY | os.O_NONBLOCK | os.O_CLOEXEC | os.O_NOCTTY)
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise _not_regular(path, mode, expected)
        _blocking(fd)
        return os.fdopen(fd, "rb")
    except BaseException:
        os.close(fd)
        raise


def read_regular_file(path: str | os.PathLike[str], max_bytes: int, *, expected: str = "a regular file") -> bytes:
    """The contents of a regular file of at most ``max_bytes`` bytes (:func:`open_for_reading`).

    At most ``max_bytes + 1`` bytes are read, whatever the file claims or becomes.

    Raises
    ------
    FileTooLargeError
        If the file is larger than ``max_bytes`` (its size is in the message).
    NotRegularFileError, OSError
        As :func:`open_for_reading`.
    """
    with open_for_reading(path, expected=expected) as handle:
        size = os.fstat(handle.fileno()).st_size
        data = handle.read(max_bytes + 1) if size <= max_bytes else b""
    if size > max_bytes or len(data) > max_bytes:
        shown = f"{size} bytes" if size > max_bytes else f"over {max_bytes} bytes"
        raise FileTooLargeError(errno.EFBIG, f"file is {shown}; expected at most {max_bytes}", os.fspath(path))
    return data


def open_for_writing(path: str | os.PathLike[str], *, expected: str = "a regular file") -> BinaryIO:
    """Create or truncate a regular file for writing (binary), never blocking on a FIFO or device.

    The file is opened with ``O_NONBLOCK`` and without ``O_TRUNC``; only once ``fstat`` on the
    opened descriptor says it is a regular file is it truncated. A FIFO without a reader fails
    at once (ENXIO), one with a reader, a device (``/dev/full``, ``/dev/null``, a terminal) or a
    directory is refused, and nothing is written to it.

    Raises
    ------
    NotRegularFileError
        If the path is, or turns out to be, anything but a regular file.
    OSError
        If it cannot be created or opened for writing (missing directory, permission, a
        read-only file system...).
    """
    try:
        mode = os.stat(path).st_mode  # refuse the obvious cases before opening (opening a device can act)
    except FileNotFoundError:
        mode = None
    except OSError:
        mode = None  # let the open report it
    if mode is not None and not stat.S_ISREG(mode):
        raise _not_regular(path, mode, expected)
    try:
        fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_NONBLOCK | os.O_CLOEXEC | os.O_NOCTTY, 0o666)
    except OSError as exc:
        if exc.errno == errno.ENXIO:  # a FIFO with no reader, created since the stat
            raise NotRegularFileError(errno.ENXIO, f"not a regular file (a FIFO); expected {expected}",
                                      os.fspath(path)) from None
        raise
    try:
        mode = os.fstat(fd).st_mode
        if not stat.S_ISREG(mode):
            raise _not_regular(path, mode, expected)
        os.ftruncate(fd, 0)
        _blocking(fd)
        return os.fdopen(fd, "wb")
    except BaseException:
        os.close(fd)
        raise


def create_new_file(path: str | os.PathLike[str]) -> os.stat_result:
    """Create ``path`` as a new, empty regular file and return its ``stat`` (for its identity).

    ``O_CREAT | O_EXCL``: if anything exists at ``path`` (a file, a dangling symlink, a FIFO)
    nothing is opened or changed and :class:`FileExistsError` is raised.

    Raises
    ------
    FileExistsError
        If the path exists.
    OSError
        If it cannot be created (missing directory, permission...).
    """
    fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NONBLOCK | os.O_CLOEXEC | os.O_NOCTTY, 0o666)
    try:
        return os.fstat(fd)
    finally:
        os.close(fd)


def check_writable_path(path: str | os.PathLike[str], *, expected: str = "a regular file") -> str | None:
    """Why ``path`` cannot be written as a regular file, or None (a cheap check before the real open).

    Its directory must exist and be writable, and the path must not exist as anything but a
    regular file (a directory, FIFO or device). :func:`open_for_writing` still checks the
    opened file, so a change between this check and the open is caught there.
    """
    p = Path(path)
    text = str(p)
    directory = p.parent if str(p.parent) else Path(".")
    try:
        mode: int | None = os.stat(p).st_mode
    except OSError:
        mode = None
    if mode is not None and stat.S_ISDIR(mode):
        return f"{text!r} is a directory; expected the path of {expected} to write"
    if mode is not None and not stat.S_ISREG(mode):
        return f"{text!r} is {file_kind(mode)}; expected the path of {expected} to write"
    if not directory.is_dir():
        return f"directory {str(directory)!r} of {text!r} does not exist"
    if not os.access(directory, os.W_OK | os.X_OK):
        return f"directory {str(directory)!r} of {text!r} is not writable"
    if mode is not None and not os.access(p, os.W_OK):
        return f"{text!r} exists and is not writable"
    return None


def same_file(a: str | os.PathLike[str], b: str | os.PathLike[str]) -> bool:
    """Whether two paths name one file: the same existing file (symlinks and hard links
    followed), or the same absolute path once symlinks in it are resolved."""
    try:
        return os.path.samefile(a, b)
    except OSError:
        return Path(a).resolve() == Path(b).resolve()


def text_writer(binary: BinaryIO) -> io.TextIOWrapper:
    """A UTF-8 text stream over ``binary`` that writes newlines as given (for CSV)."""
    return io.TextIOWrapper(binary, encoding="utf-8", newline="")
