"""docs/case-format.md's tables, generated from the type declarations (the
registry and the key kinds) and the loader's limits; tests keep the page
equal to them. Regenerate with ``python -m kinem.constraints.docs``."""
from pathlib import Path

from ..casefile import checks
from . import REGISTRY

PAGE = Path(__file__).resolve().parents[2] / "docs" / "case-format.md"


def begin(name) -> str:
    return f"<!-- generated: {name} (python -m kinem.constraints.docs; do not edit by hand) -->"


END = "<!-- end of generated table -->"


def types() -> str:
    rows = ["| type | equations | keys |", "|---|---|---|"]
    for name, decl in REGISTRY.items():
        keys = ", ".join(k.name + ("" if k.required else " (optional)") for k in decl.keys)
        rows.append(f"| `{name}` | {decl.equations} | {keys} |")
    return "\n".join(rows) + "\n"


def keys() -> str:
    rows = ["| type | key | value | meaning |", "|---|---|---|---|"]
    for name, decl in REGISTRY.items():
        for k in decl.keys:
            doc = (k.doc + ("" if k.required else (" (optional)" if k.doc else "optional"))).replace("|", r"\|")
            rows.append(f"| `{name}` | `{k.name}` | {k.accepts} | {doc} |")
    return "\n".join(rows) + "\n"


def limits() -> str:
    rows = ["| what | rule |", "|---|---|"]
    rows += [f"| {what} | {rule} |" for what, rule in checks.LIMITS]
    return "\n".join(rows) + "\n"


TABLES = {"constraint types": types, "constraint keys": keys, "limits": limits}


def render(text: str) -> str:
    """The page with every generated table replaced by its current content."""
    for name, make in TABLES.items():
        head, sep, rest = text.partition(begin(name))
        if not sep:
            raise ValueError(f"{PAGE}: no marker for the generated table '{name}'")
        _, sep, tail = rest.partition(END)
        text = head + begin(name) + "\n" + make() + END + tail
    return text


def update(path=PAGE) -> bool:
    text = Path(path).read_text()
    new = render(text)
    if new != text:
        Path(path).write_text(new)
    return new != text


if __name__ == "__main__":
    print(f"{PAGE} " + ("updated" if update() else "already current"))
