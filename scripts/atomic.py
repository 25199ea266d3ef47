"""Atomic file writing for the scripts: a temporary file in the target's
folder, renamed into place, so no reader ever sees a partial file."""
import os
import tempfile


def current_umask():
    m = os.umask(0)
    os.umask(m)
    return m


def write_atomic(path, text):
    """Writes text to path through a temporary file in path's folder (made if
    missing), with the permissions a plain open() would give."""
    d = os.path.dirname(os.path.abspath(path))
    os.makedirs(d, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", dir=d)
    try:
        with os.fdopen(fd, "w") as f:
            f.write(text)
        os.chmod(tmp, 0o666 & ~current_umask())
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise
