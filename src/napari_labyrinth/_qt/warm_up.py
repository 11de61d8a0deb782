"""The warm-up process of a viewer: numba's kernels compiled out of napari's process.

:class:`WarmUp` runs ``python -m napari_labyrinth._warmup`` in a
:class:`~qtpy.QtCore.QProcess` as the widget opens, reads the steps it
prints (the widget shows them while a run waits for it) and ends it when the
widget closes with its dock or viewer. One warm-up is started per session:
it fills numba's disk cache, which every later widget and run loads.
"""

from __future__ import annotations

from collections.abc import Callable

from qtpy.QtCore import QObject, QProcess

from .. import _warmup

#: What the widget says while the kernels compile: once after an install.
PREPARING = "Preparing the kernels for this machine, once after an install"

_started = False


class WarmUp(QObject):
    """The warm-up process, if this widget started one.

    Parameters
    ----------
    on_line : callable
        Called with each line the process prints (``step K of N: what``,
        ``kernel NAME``, ``done``).
    on_end : callable
        Called once the process has ended, however it ended.
    parent : QObject
        Owner of the process: the process ends with it.
    """

    def __init__(self, on_line: Callable[[str], None], on_end: Callable[[], None], parent=None):
        super().__init__(parent)
        self._on_line = on_line
        self._on_end = on_end
        self._process: QProcess | None = None
        #: What the process printed after its last complete line: a read can end mid-line.
        self._partial = b""
        self.step = ""
        #: Steps the process has finished (each is a kind of run: the render, the metrics).
        self.steps_done = 0

    @property
    def running(self) -> bool:
        """Whether the process is still compiling."""
        return self._process is not None and self._process.state() != QProcess.NotRunning

    def start(self, dtype: str) -> bool:
        """Start the warm-up for images of ``dtype`` unless one was started this session,
        warm-ups are disabled (``_warmup.DISABLE_VARIABLE``) or the install's shipped
        kernels load (nothing to compile: ``_warmup.needed``); whether it started."""
        global _started
        if _started or _warmup.disabled() or not _warmup.needed():
            return False
        _started = True
        program, *arguments = _warmup.command("--dtype", dtype)
        process = QProcess(self)
        process.setProcessChannelMode(QProcess.SeparateChannels)
        process.readyReadStandardOutput.connect(self._read)
        process.finished.connect(self._ended)
        process.errorOccurred.connect(self._failed)
        self._process = process
        process.start(program, arguments)
        return True

    def stop(self) -> None:
        """End the process now (the widget is closing)."""
        process, self._process = self._process, None
        if process is not None and process.state() != QProcess.NotRunning:
            process.finished.disconnect(self._ended)
            process.kill()
            process.waitForFinished(1000)

    def _read(self) -> None:
        if self._process is None:
            return
        self.feed(bytes(self._process.readAllStandardOutput()))

    def feed(self, data: bytes, *, end: bool = False) -> None:
        """Take what the process printed, as a read returned it: the lines it completes are
        handled, each once and whole; the rest waits for the next read (``end``: the process
        has ended, and the rest is a line too). Empty lines are skipped."""
        data = self._partial + data
        if end:
            complete, self._partial = data, b""
        else:
            complete, newline, rest = data.rpartition(b"\n")
            self._partial = rest
            if not newline:
                return
        for line in complete.decode(errors="replace").splitlines():
            line = line.strip()
            if not line:
                continue
            if line.startswith("step "):  # step K of N: what
                self.step = line.replace(": ", ", ", 1)
                self.steps_done = int(line.split()[1]) - 1
            self._on_line(line)

    def done_with(self, steps: int) -> bool:
        """Whether the first ``steps`` steps are done (or the process has ended)."""
        return not self.running or self.steps_done >= steps

    def _ended(self, *_args) -> None:
        self._read()
        self.feed(b"", end=True)
        self._process = None
        self._on_end()

    def _failed(self, error) -> None:
        if error == QProcess.FailedToStart:  # no interpreter to start: runs compile in process
            self._ended()
