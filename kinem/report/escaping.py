"""Text the report did not write itself (a case's description, a file
path, a message quoting either, a baseline's names) made safe where the
report puts it: ``escape`` for index.html, ``md`` for a line of summary.md,
``xml_text``/``xml_attr`` for junit.xml. Each first shows a control or
invisible formatting character (C0 but tab and newline, DEL, C1,
zero-width and bidirectional controls such as U+202E, which would reorder
what the reader sees) as its ``\\uXXXX`` code, so that nothing hides or
spoofs text and junit.xml stays valid XML 1.0."""
import html
from xml.sax import saxutils

from ..casefile.checks import HIDDEN   # refused in a description; a path, a message or a baseline may hold them


def visible(text) -> str:
    """text with every HIDDEN character as its \\uXXXX code."""
    return HIDDEN.sub(lambda m: f"\\u{ord(m.group()):04x}", str(text))


def escape(text, quote=True) -> str:
    """html.escape of the visible text."""
    return html.escape(visible(text), quote)


def md(text) -> str:
    """Text for one line of Markdown (a list item or a table cell): visible,
    on one line, '|' and '<' escaped (no table cell ends early, no HTML tag)."""
    return visible(text).replace("\n", " ").replace("\t", " ").replace("|", "\\|").replace("<", "\\<")


def xml_text(text) -> str:
    return saxutils.escape(visible(text))


def xml_attr(text) -> str:
    return saxutils.quoteattr(visible(text))
