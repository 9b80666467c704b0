"""The size of a `.npz` file's arrays, known before any is read: a zip of `.npy` members compresses
zeros a thousandfold, so a 2 MB file can hold a 2 GiB array. `npz_problem` reads only the zip's
directory (each member's uncompressed size: a zip member never yields more than that) and each
member's `.npy` header (shape and dtype: what numpy would allocate before reading the data), and
says why the file is too large or inconsistent. Milliseconds, whatever the file claims."""

from __future__ import annotations

import math
import zipfile
from pathlib import Path

import numpy as np

MAX_MEMBERS = 256  # arrays in one file: models and datasets hold a few dozen


def npz_problem(path: str | Path, max_bytes: int, max_members: int = MAX_MEMBERS) -> str | None:
    """Why the `.npz` at `path` may not be loaded (its arrays larger than `max_bytes` in all,
    uncompressed; more than `max_members` of them; a header promising more data than its member
    holds; not a zip of `.npy` arrays), or None."""
    try:
        with zipfile.ZipFile(path) as archive:
            members = archive.infolist()
            if len(members) > max_members:
                return f"{len(members)} arrays, at most {max_members}"
            total = sum(m.file_size for m in members)
            if total > max_bytes:
                return f"its arrays take {_size(total)} uncompressed, at most {_size(max_bytes)}"
            for member in members:
                problem = _member_problem(archive, member, max_bytes)
                if problem:
                    return problem
    except (zipfile.BadZipFile, OSError, EOFError, ValueError) as exc:
        return f"not an .npz archive of arrays ({type(exc).__name__}: {exc})"
    return None


def _member_problem(archive: zipfile.ZipFile, member: zipfile.ZipInfo, max_bytes: int) -> str | None:
    """Why one `.npy` member's header promises too much, or None."""
    with archive.open(member) as f:
        version = np.lib.format.read_magic(f)
        if version == (1, 0):
            shape, _, dtype = np.lib.format.read_array_header_1_0(f)
        elif version == (2, 0):
            shape, _, dtype = np.lib.format.read_array_header_2_0(f)
        else:
            return f"{member.filename}: .npy format {version[0]}.{version[1]} is not read"
    declared = math.prod(int(n) for n in shape) * dtype.itemsize  # Python ints: no overflow
    if declared > max_bytes:
        return f"{member.filename}: an array of {_size(declared)} ({'x'.join(map(str, shape))} {dtype}), " \
               f"at most {_size(max_bytes)}"
    if declared > member.file_size:
        return f"{member.filename}: its header promises {declared} bytes, the file holds {member.file_size}"
    return None


def _size(n: int) -> str:
    return f"{n / (1 << 20):.0f} MiB" if n >= 1 << 20 else f"{n} bytes"
