"""Files the operators write: the folder an export or a video goes in."""

from __future__ import annotations

from pathlib import Path


def make_folder(path: Path) -> str | None:
    """Make the folder the file ``path`` goes in (and its parents): None, or why it cannot be
    written there (for the exports' and Make Video's reports). A name the file system refuses
    (too long) fails the checks themselves: that is a reason too, not a traceback."""
    try:
        if path.is_dir():
            return "it is a folder"
        blocker = next((p for p in path.parents if p.exists()), None)
        if blocker is not None and not blocker.is_dir():
            return f"'{blocker}' is a file, not a folder"
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        return err.strerror or str(err)
    return None
