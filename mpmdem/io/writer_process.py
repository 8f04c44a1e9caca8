"""Frames written by a child process: a batch's run files off the Python of the process that steps.

A batch of worlds writes a frame of every world's file at every frame time (HDF5 stores, the XDMF
views, the CSV row: a few milliseconds of Python each). In a thread of the stepping process that
work takes Python's lock from the thread that reads the frame back and launches the next steps, and
the device waits for both (``mpmdem.io.background``). Here a spawned child process owns some of the
files (each a ``FrameWriter``) and writes what it is sent, in order, while the parent goes on
(``BatchedSimulation`` deals its worlds to ``Tuning.batch_writer_processes`` children). The child
runs this module's ``main`` (``CHILD``: the run files' modules without Warp) in a session of its
own, fed pickled messages on its stdin by a feeder thread of the parent (the caller only queues
them; the arrays' bytes follow each pickle out of band, written from their own memory), answering
on its stdout (not ``multiprocessing``'s spawn, which would run a user's script again in the child).

What a run keeps of ``BackgroundFrameWriter``'s promises:

- frames are written one after another per file, in order, each flushed as it is written; the
  parent holds at most ``max_pending`` frames a file in flight (the next waits for the child);
- an error of a write is raised in the parent by the next call on that file (``RuntimeError``
  naming it and the child's message); a file the child could not create raises at ``open``;
- ``set_status`` and ``close`` go after every frame sent before them; ``close`` returns once the
  child has closed the file;
- Ctrl-C and SIGTERM reach the parent only (the child is in its own session and ignores them: the
  parent marks the files and closes them); a parent that dies without closing (killed) closes the
  child's stdin, and the child writes what it received and closes every file, so each stays readable;
- a child that dies is an error at the parent's next wait, which names its exit code.
"""

from __future__ import annotations

import collections
import os
import pickle
import queue
import signal
import subprocess
import sys
import threading
import traceback
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from .closing import ClosesOnExit

__all__ = ["ProcessFrameWriter", "WriterProcess"]

#: seconds between the parent's checks that its child still runs while it waits for a reply
POLL_S = 0.5

#: The child's program (argument: the folder of the ``mpmdem`` package): ``main`` of this module, with
#: ``mpmdem`` a bare package of that folder, so that the child imports the run files' modules alone,
#: not the package's ``__init__`` (Warp and the simulation: about 1 s of a child's start, against 0.2 s)
CHILD = ("import sys, types; package = types.ModuleType('mpmdem'); package.__path__ = [sys.argv[1]]; "
         "sys.modules['mpmdem'] = package; from mpmdem.io.writer_process import main; main()")


def _write_message(stream, message) -> None:
    """Send ``message`` pickled (protocol 5), its arrays' bytes out of band: written straight from
    their memory after the pickle, not copied into it. Framing: the pickle's size, the count of
    buffers and each buffer's size (8-byte little-endian each), the pickle, the buffers."""
    buffers: list[pickle.PickleBuffer] = []
    data = pickle.dumps(message, protocol=5, buffer_callback=buffers.append)
    raws = [b.raw() for b in buffers]
    stream.write(b"".join(n.to_bytes(8, "little") for n in (len(data), len(raws), *(r.nbytes for r in raws))))
    stream.write(data)
    for raw in raws:
        stream.write(raw)
    stream.flush()


def _read_exactly(stream, size: int) -> bytearray | None:
    """``size`` bytes of ``stream``, or None if it ends first."""
    out = bytearray(size)
    view, got = memoryview(out), 0
    while got < size:
        n = stream.readinto(view[got:])
        if not n:
            return None
        got += n
    return out


def _read_message(stream):
    """The next message, or None at the end of the stream."""
    head = _read_exactly(stream, 16)
    if head is None:
        return None
    size, count = int.from_bytes(head[:8], "little"), int.from_bytes(head[8:], "little")
    sizes = _read_exactly(stream, 8 * count)
    data = _read_exactly(stream, size)
    if sizes is None or data is None:
        return None
    buffers = []
    for k in range(count):
        buffer = _read_exactly(stream, int.from_bytes(sizes[8 * k:8 * k + 8], "little"))
        if buffer is None:
            return None
        buffers.append(buffer)
    return pickle.loads(data, buffers=buffers)


def serve(requests, replies) -> None:
    """The child: FrameWriters by key, fed from the ``requests`` stream until a "stop" or its end;
    acknowledgements and errors to ``replies``; then every file still open is closed."""
    from .writer import FrameWriter

    writers: dict[int, FrameWriter] = {}
    broken: set[int] = set()
    while (message := _read_message(requests)) is not None:
        kind, key = message[0], message[1]
        if kind == "stop":
            break
        try:
            if kind == "open":
                writers[key] = FrameWriter(**message[2])
            elif key in broken and kind == "frame":
                pass  # (after a failed frame the file takes no more; its status and close still go)
            elif kind == "frame":
                writers[key].write_frame(*message[2:])
            elif kind == "status":
                writers[key].set_status(*message[2:])
            elif kind == "close":
                writer = writers.pop(key, None)
                broken.discard(key)
                if writer is not None:
                    writer.close()
            reply = ("done", key, kind)
        except BaseException:  # noqa: BLE001  (the parent raises it at its next call on the file)
            broken.add(key)
            reply = ("error", key, kind, traceback.format_exc(limit=4))
        _write_message(replies, reply)
    for writer in writers.values():  # (stopped, or the parent is gone: every file closed, readable)
        try:
            writer.close()
        except Exception:  # noqa: BLE001
            pass


class WriterProcess(ClosesOnExit):
    """One child process writing the frames of several run files (module docstring).

    Args:
        max_pending: frames of one file sent and not yet written before the next ``write_frame``
            waits (memory in flight: the frames' arrays, pickled).
    """

    def __init__(self, max_pending: int = 2):
        self.max_pending = int(max_pending)
        package = str(Path(__file__).resolve().parents[1])
        self._process = subprocess.Popen([sys.executable, "-c", CHILD, package], stdin=subprocess.PIPE,
                                         stdout=subprocess.PIPE, start_new_session=True)
        self._outbox: queue.Queue = queue.Queue()
        self._replies: queue.Queue = queue.Queue()
        self._feeder = threading.Thread(target=self._feed, name="mpmdem-writer-feed", daemon=True)
        self._reader = threading.Thread(target=self._read, name="mpmdem-writer-replies", daemon=True)
        self._feeder.start()
        self._reader.start()
        self._pending: collections.Counter = collections.Counter()
        self._errors: dict[int, str] = {}
        self._keys = 0
        self._closed = False

    def _feed(self) -> None:
        stdin = self._process.stdin
        try:
            while (message := self._outbox.get()) is not None:
                _write_message(stdin, message)
        except (BrokenPipeError, OSError):  # (the child ended: ``wait`` says so)
            pass
        finally:
            try:
                stdin.close()
            except OSError:
                pass

    def _read(self) -> None:
        while (reply := _read_message(self._process.stdout)) is not None:
            self._replies.put(reply)

    def open(self, path: str | os.PathLike, **kwargs: Any) -> ProcessFrameWriter:
        """A ``FrameWriter(path, **kwargs)`` made in the child; its errors are raised here."""
        key = self._keys
        self._keys += 1
        self._send(("open", key, {"path": str(path), **kwargs}))
        self.wait(key, 1)
        return ProcessFrameWriter(self, key, Path(path))

    def _send(self, message: tuple) -> None:
        if self._closed:
            raise RuntimeError("the frame writer process was closed")
        self._pending[message[1]] += 1
        self._outbox.put(message)

    def wait(self, key: int, below: int) -> None:
        """Return once fewer than ``below`` messages for file ``key`` are in flight; raise the child's
        error for that file, or the child's death."""
        while self._pending[key] >= below and key not in self._errors:
            try:
                reply = self._replies.get(timeout=POLL_S)
            except queue.Empty:
                if self._process.poll() is not None:
                    raise RuntimeError(f"the frame writer process ended (exit code {self._process.returncode}) "
                                       "with frames still to write") from None
                continue
            self._pending[reply[1]] -= 1
            if reply[0] == "error":
                self._errors[reply[1]] = f"{reply[2]}: {reply[3].strip().splitlines()[-1]}"
        if key in self._errors:
            raise RuntimeError(f"the frame writer process failed on file {key} ({self._errors.pop(key)})")

    def close(self) -> None:
        """Stop the child once it has written everything sent; closing twice is harmless."""
        if self._closed:
            return
        self._closed = True
        self._outbox.put(("stop", -1))
        self._outbox.put(None)
        self._feeder.join()
        self._process.wait()
        self._reader.join()


class ProcessFrameWriter(ClosesOnExit):
    """One run file of a ``WriterProcess``, with ``BackgroundFrameWriter``'s calls."""

    def __init__(self, owner: WriterProcess, key: int, path: Path):
        self._owner, self._key, self.path = owner, key, path
        self._open = True

    def write_frame(self, time: float, fields: Mapping[str, np.ndarray] | None, diagnostics: Mapping[str, float],
                    body_fields: Mapping[str, np.ndarray] | None = None) -> None:
        """Send one frame (``FrameWriter.write_frame``) once fewer than ``max_pending`` are in flight."""
        self._owner.wait(self._key, self._owner.max_pending)
        self._owner._send(("frame", self._key, float(time), fields, dict(diagnostics), body_fields))

    def wait(self) -> None:
        """Return once every frame sent is written; raise a write's error."""
        self._owner.wait(self._key, 1)

    def set_status(self, status: str, message: str = "") -> None:
        """``FrameWriter.set_status`` after the frames sent (marked even if one of them failed)."""
        try:
            self.wait()
        finally:
            self._owner._send(("status", self._key, status, message))
            self._owner.wait(self._key, 1)

    def close(self) -> None:
        """Close the file once everything sent is written; closing twice is harmless."""
        if not self._open:
            return
        self._open = False
        try:
            self.wait()
        finally:
            self._owner._send(("close", self._key))
            self._owner.wait(self._key, 1)


def main() -> None:
    """``python -m mpmdem.io.writer_process``: serve the parent on stdin and stdout (module docstring)."""
    for sig in (signal.SIGINT, signal.SIGTERM):
        signal.signal(sig, signal.SIG_IGN)
    replies = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    sys.stdout = sys.stderr  # (nothing else may write to the replies' stream)
    serve(sys.stdin.buffer, replies)


if __name__ == "__main__":
    main()
