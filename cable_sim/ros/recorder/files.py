"""Files a recording is written to: never an existing one (``<stem>-1``, ...), fsync on demand.

May import only the standard library.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path
from typing import Any


class _Sink:
    """Buffered binary file that the MCAP writer writes to; can be flushed to disk (fsync)."""

    def __init__(self, f: Any) -> None:
        self.f = f

    def write(self, data: bytes) -> int:
        return self.f.write(data)

    def tell(self) -> int:
        return self.f.tell()

    def flush(self) -> None:
        self.f.flush()

    def sync(self) -> None:
        self.f.flush()
        os.fsync(self.f.fileno())

    def close(self) -> None:
        self.f.close()



MAX_NAME_ATTEMPTS = 10_000


def open_new_file(path: Path) -> tuple[Any, Path]:
    """Open a *new* file for writing, never an existing one; return ``(file, path used)``.

    The file is created exclusively (``open(..., "xb")``, O_CREAT | O_EXCL), so two writers that
    ask for the same name at the same instant cannot both get it. When ``path`` exists as a
    regular file (or a link to one), it is left untouched and ``<stem>-1<suffix>``,
    ``<stem>-2<suffix>``, ... are tried instead. An existing non-regular file that is not a
    directory (a device such as ``/dev/full``, a FIFO) holds nothing to destroy and is opened
    for writing as it is.

    Parameters
    ----------
    path : Path
        Requested file.

    Returns
    -------
    file : binary file object
        Open for writing.
    path : Path
        The file actually opened (``path`` itself unless it existed).

    Raises
    ------
    OSError
        ``IsADirectoryError`` when ``path`` is a directory, ``FileExistsError`` when
        :data:`MAX_NAME_ATTEMPTS` names are all taken, or the error of ``open`` itself.
    """
    for i in range(MAX_NAME_ATTEMPTS):
        p = path if i == 0 else path.with_name(f"{path.stem}-{i}{path.suffix}")
        try:
            return open(p, "xb"), p  # noqa: SIM115 - closed by _Sink.close()
        except FileExistsError:
            if p.is_dir():
                raise IsADirectoryError(errno.EISDIR, os.strerror(errno.EISDIR), str(p)) from None
            if p.exists() and not p.is_file():  # device / FIFO: nothing to overwrite
                return open(p, "wb"), p  # noqa: SIM115
    raise FileExistsError(errno.EEXIST, f"{path} and {MAX_NAME_ATTEMPTS - 1} numbered alternatives "
                          "exist", str(path))
