"""Output folders and files of the commands: no silent overwrite, atomic writes."""

from __future__ import annotations

import os
import tempfile
from collections.abc import Collection, Iterator
from contextlib import contextmanager
from pathlib import Path

from surrogates.io import new_file_mode

__all__ = ["atomic_path", "prepare_output_dir", "write_text_atomic"]


def prepare_output_dir(
    out: str | Path, overwrite: bool = False, flag: str = "--out", own: Collection[str] = ()
) -> Path:
    """Create the output folder ``out``, or check that an existing one may be written.

    An existing folder must be empty, or hold only files named in ``own`` (the files the
    command writes, replaced on a re-run), unless ``overwrite``; ``flag`` names the option in
    the error. Called before any work, so that a bad path fails at once.

    Raises
    ------
    ValueError
        ``out`` is a file, a non-empty folder without ``overwrite``, or cannot be created.
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"{flag} {out}: exists and is not a folder")
    foreign = sorted(p.name for p in out.iterdir() if p.name not in own) if out.is_dir() else []
    if foreign and not overwrite:
        what = repr(foreign[0]) + (f" and {len(foreign) - 1} more" if foreign[1:] else "")
        mine = f"; it may hold only {', '.join(sorted(own))}" if own else ""
        raise ValueError(
            f"{flag} {out}: folder exists and is not empty (holds {what}{mine}); pass "
            "--overwrite to replace its files"
        )
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise ValueError(f"{flag} {out}: cannot create the folder ({err.strerror})") from None
    if not os.access(out, os.W_OK):
        raise ValueError(f"{flag} {out}: folder is not writable")
    return out


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """A temporary path beside ``path`` (same suffix) that replaces ``path`` atomically when the
    block succeeds; removed when it fails. It has the permission bits of the umask."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem}.", suffix=path.suffix, dir=path.parent)
    os.close(fd)
    os.chmod(tmp, new_file_mode())
    try:
        yield Path(tmp)
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.remove(tmp)


def write_text_atomic(path: str | Path, text: str) -> None:
    """Write ``text`` (UTF-8) to ``path`` through a temporary file and an atomic rename."""
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
