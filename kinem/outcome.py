"""How a run of kinem ended, one type for all of them: a streamed solve
(kinem.stream), a report (kinem.report), a stress scenario (kinem.stress).

An ``Outcome`` holds a ``status``, a member of a ``Kind`` enum: its ``value``
is what JSON stores, its ``message`` what people read and ``failure`` whether
it fails the run (optimistix's RESULTS); ``detail``, the specifics of this
run; ``value``, what the run produced (a frozen record of the caller's).
"""
import enum
from dataclasses import dataclass


class Kind(str, enum.Enum):
    """Base of the status enums: ``Member = (value, message[, failure])``."""

    def __new__(cls, value, message, failure=False):
        member = str.__new__(cls, value)
        member._value_ = value
        member.message = message
        member.failure = failure
        return member


@dataclass(frozen=True)
class Outcome:
    status: Kind
    detail: str = ""          # the specifics ("" when the status says it all)
    value: object = None      # what the run produced

    @property
    def success(self) -> bool:
        return not self.status.failure

    @property
    def exit_code(self) -> int:
        """The command line's: 0, or 1 for a failed analysis or check."""
        return 1 if self.status.failure else 0

    @property
    def message(self) -> str:
        """The status's message and the detail: one line for people."""
        return f"{self.status.message}: {self.detail}" if self.detail else self.status.message
