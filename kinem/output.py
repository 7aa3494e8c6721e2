"""Writing trajectories: CSV (header of column names, one row per instant,
17 significant digits) or NPZ (arrays t, data, columns). Files are written to
a temporary file beside the target and renamed into place, so a failed or
interrupted run never leaves a partial file."""
import io
import os
import tempfile
from pathlib import Path

import numpy as np


def csv_text(traj) -> str:
    buf = io.StringIO()
    buf.write(",".join(("t",) + traj.columns) + "\n")
    np.savetxt(buf, np.column_stack([traj.t, traj.data]), fmt="%.17g", delimiter=",")
    return buf.getvalue()


def write_atomic(path, write) -> None:
    """Calls write(binary file object) on a temporary file, then renames it to path."""
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent or ".")
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600: give the file the mode a plain open() would
    try:
        with os.fdopen(fd, "wb") as f:
            write(f)
        os.replace(tmp, path)
    except BaseException:
        os.unlink(tmp)
        raise


def write_trajectory(traj, path, fmt="csv") -> None:
    if fmt == "csv":
        text = csv_text(traj).encode()
        write_atomic(path, lambda f: f.write(text))
    else:
        write_atomic(path, lambda f: np.savez(f, t=traj.t, data=traj.data, columns=np.array(traj.columns)))
