"""Output files checked before an episode is run for them (no MuJoCo imported)."""

from __future__ import annotations

import os
import pathlib
import tempfile


def writable(path, suffixes: tuple[str, ...], what: str) -> pathlib.Path:
    """`path`, or a ValueError naming what is wrong with it for a `what` ("video", "page"):
    its suffix not one of `suffixes`, a parent that is a file, a folder or file that cannot be
    written."""
    path = pathlib.Path(path)
    if path.suffix.lower() not in suffixes:
        raise ValueError(f"{what} path must end in {' or '.join(suffixes)}, got {path.name!r}")
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                raise ValueError(
                    f"cannot write the {what} {path}: {parent} is a file, not a folder; "
                    "choose a path in a folder"
                )
            try:  # a file can be made there (a read-only folder or file system, /proc, ...)
                tempfile.TemporaryFile(dir=parent).close()
            except OSError as e:
                raise ValueError(
                    f"cannot write the {what} {path}: {parent} takes no new file ({e.strerror}); "
                    "choose another folder"
                ) from None
            break
    if path.is_dir():
        raise ValueError(f"cannot write the {what} {path}: it is a folder")
    if path.exists() and not os.access(path, os.W_OK):
        raise ValueError(f"cannot write the {what} {path}: the file is read-only")
    return path
