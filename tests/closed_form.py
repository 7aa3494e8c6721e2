"""The closed forms live in kinem.reference (the report and the stress suite use them too)."""
from kinem.reference import four_bar, rel_error, slider_crank, wrap  # noqa: F401
