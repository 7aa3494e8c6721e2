"""A one-line progress bar on standard error when it is a terminal; silent
otherwise, so CI logs stay clean."""
import sys
import time


class Progress:
    def __init__(self, total, stream=None, enabled=None):
        self.stream = stream or sys.stderr
        self.enabled = self.stream.isatty() if enabled is None else enabled
        self.total, self.done, self.start = total, 0, time.monotonic()

    def drop(self, n):
        """n planned runs will not happen (their main run failed)."""
        self.total -= n
        self.show("")

    def step(self, label):
        self.done += 1
        self.show(label)

    def show(self, label):
        if not self.enabled:
            return
        width = 30
        filled = int(width * self.done / max(self.total, 1))
        line = (f"\r[{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total} "
                f"{time.monotonic() - self.start:5.0f} s  {label}")
        self.stream.write(line[:110].ljust(110))
        self.stream.flush()

    def close(self):
        if self.enabled:
            self.stream.write("\r" + " " * 110 + "\r")
            self.stream.flush()
