"""A child process that triangulates point sets with gmsh: ``python -m fepre.distmesh.delaunay_worker``.

It reads requests on stdin (an int64 count ``n``, then ``n`` x 3 float64 coordinates) and answers
each on stdout (an int64 count ``m``, then ``m`` x 4 int32 corners, or ``-1`` and a UTF-8 error
message of int64 length). It ends at the end of its input. It is a separate process, not a thread,
because gmsh breaks ties between co-spherical points with the C library's ``rand``: two threads
would share it and make the result depend on timing. It is started with its own interpreter (not
``multiprocessing``) so that a user's script without a ``__main__`` guard is never imported twice.
"""

from __future__ import annotations

import sys

import numpy as np


def _read_exactly(stream, size: int) -> bytes:
    chunks, left = [], size
    while left:
        chunk = stream.read(left)
        if not chunk:
            raise EOFError
        chunks.append(chunk)
        left -= len(chunk)
    return b"".join(chunks)


def serve(source, sink) -> None:
    """Answer requests from the binary stream ``source`` on ``sink`` until ``source`` ends."""
    from .delaunay import _gmsh

    while True:
        try:
            count = int(np.frombuffer(_read_exactly(source, 8), np.int64)[0])
            points = np.frombuffer(_read_exactly(source, 24 * count), np.float64).reshape(count, 3)
        except EOFError:
            return
        try:
            tets = _gmsh(points).astype(np.int32)
        except Exception as exc:  # reported to the parent, which raises it there
            message = str(exc).encode()
            sink.write(np.array([-1, len(message)], np.int64).tobytes() + message)
        else:
            sink.write(np.array([len(tets)], np.int64).tobytes())
            sink.write(np.ascontiguousarray(tets).tobytes())
        sink.flush()


if __name__ == "__main__":
    serve(sys.stdin.buffer, sys.stdout.buffer)
