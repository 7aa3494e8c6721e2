"""The results.json schema (schema.json, JSON Schema draft 2020-12) and a
checker for the subset of JSON Schema it uses: type (one or a list),
properties, required, additionalProperties, items, enum, const, minimum and
local $ref to $defs. (jsonschema is not a dependency.)"""
import json
from pathlib import Path

SCHEMA = json.loads((Path(__file__).parent / "schema.json").read_text(encoding="utf-8"))

_TYPES = {"object": dict, "array": list, "string": str, "boolean": bool, "null": type(None)}


def _is(value, kind):
    if kind == "number":
        return isinstance(value, (int, float)) and not isinstance(value, bool)
    if kind == "integer":
        return isinstance(value, int) and not isinstance(value, bool)
    return isinstance(value, _TYPES[kind])


def problems(value, schema, root=None, where="$") -> list:
    """Every place where value breaks schema, as 'path: problem' lines."""
    root = root or schema
    if "$ref" in schema:
        name = schema["$ref"].rsplit("/", 1)[-1]
        return problems(value, root["$defs"][name], root, where)
    kinds = schema.get("type")
    if kinds is not None:
        kinds = [kinds] if isinstance(kinds, str) else kinds
        if not any(_is(value, k) for k in kinds):
            return [f"{where}: got {type(value).__name__}; expected {' or '.join(kinds)}"]
    out = []
    if "const" in schema and value != schema["const"]:
        out.append(f"{where}: got {value!r}; expected {schema['const']!r}")
    if "enum" in schema and value not in schema["enum"]:
        out.append(f"{where}: got {value!r}; expected one of {schema['enum']}")
    if "minimum" in schema and _is(value, "number") and value < schema["minimum"]:
        out.append(f"{where}: got {value}; expected at least {schema['minimum']}")
    if isinstance(value, dict):
        for key in schema.get("required", ()):
            if key not in value:
                out.append(f"{where}: missing key '{key}'")
        props = schema.get("properties", {})
        extra = schema.get("additionalProperties", True)
        for key, v in value.items():
            if key in props:
                out += problems(v, props[key], root, f"{where}.{key}")
            elif extra is False:
                out.append(f"{where}: unknown key '{key}'")
            elif isinstance(extra, dict):
                out += problems(v, extra, root, f"{where}.{key}")
    if isinstance(value, list) and "items" in schema:
        for k, v in enumerate(value):
            out += problems(v, schema["items"], root, f"{where}[{k}]")
    return out
