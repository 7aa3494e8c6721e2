"""A one-line progress bar on standard error when it is a terminal; silent
otherwise, so CI logs stay clean. It covers the whole report (runs, stress
suite, figures) and always says what it waits for: the runs still going,
redrawn at least every TICK seconds so the clock never stands still."""
import os
import sys
import time
from concurrent.futures import FIRST_COMPLETED, wait

TICK = 1.0     # seconds between redraws while nothing finishes
WIDTH = 110    # characters of the line


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

    def waiting(self, labels):
        """Redraw with the runs still going."""
        labels = list(labels)
        more = f" +{len(labels) - 2}" if len(labels) > 2 else ""
        self.show("waiting for " + ", ".join(labels[:2]) + more if labels else "")

    def show(self, label):
        if not self.enabled:
            return
        width = 30
        filled = int(width * min(self.done, self.total) / max(self.total, 1))
        line = (f"\r[{'#' * filled}{'.' * (width - filled)}] {self.done}/{self.total} "
                f"{time.monotonic() - self.start:5.0f} s  {label}")
        self.stream.write(line[:WIDTH].ljust(WIDTH))
        self.stream.flush()

    def close(self):
        if self.enabled:
            self.stream.write("\r" + " " * WIDTH + "\r")
            self.stream.flush()


def run_all(fn, tasks, labels, workers=None, scheduler=None, bar=None) -> list:
    """[fn(t) for t in tasks] where kinem.parallel puts them, in task order,
    stepping bar (labels: one per task) as each finishes."""
    from .. import parallel

    out = [None] * len(tasks)
    with parallel.executor(workers, scheduler) as pool:
        if pool is None:
            for k, t in enumerate(tasks):
                if bar:
                    bar.waiting([labels[k]])
                out[k] = fn(t)
                if bar:
                    bar.step(labels[k])
            return out
        running = {pool.submit(fn, t): k for k, t in enumerate(tasks)}
        while running:
            done, _ = wait(running, timeout=TICK, return_when=FIRST_COMPLETED)
            for f in done:
                k = running.pop(f)
                out[k] = f.result()
                if bar:
                    bar.step(labels[k])
            if bar and not done:
                bar.waiting(labels[k] for k in sorted(running.values())[:os.cpu_count() or 1])
    return out
