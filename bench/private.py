"""Private files whatever the umask: the data directory 0700, store files 0600.

The run store and the API keys live in one data directory; with a permissive umask (000)
it was created 0777, so anyone on the host could add an admin key or read the runs.
"""
from __future__ import annotations

import os
import stat
from pathlib import Path


def private_dir(path: str | Path) -> Path:
    """Create ``path`` (and parents) and make it 0700 if this user owns it."""
    p = Path(path)
    p.mkdir(parents=True, exist_ok=True)
    st = p.stat()
    if st.st_uid == os.geteuid() and stat.S_IMODE(st.st_mode) != 0o700:
        os.chmod(p, 0o700)
    return p


def private_file(path: str | Path) -> Path:
    """Create ``path`` empty if missing, 0600 from the start; an existing one of ours is
    made 0600."""
    p = Path(path)
    fd = os.open(p, os.O_WRONLY | os.O_CREAT, 0o600)
    os.close(fd)
    if p.stat().st_uid == os.geteuid():
        os.chmod(p, 0o600)
    return p


def trusted(path: str | Path) -> str | None:
    """Why the file at ``path`` must not be trusted (another owner, or writable by group or
    others), or None."""
    st = Path(path).stat()
    if st.st_uid != os.geteuid():
        return f"{path} is owned by uid {st.st_uid}, not by this server's user ({os.geteuid()})"
    if st.st_mode & 0o022:
        return f"{path} is writable by group or others (mode {stat.S_IMODE(st.st_mode):04o}); chmod 600 it"
    return None
