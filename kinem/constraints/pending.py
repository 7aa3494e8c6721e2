"""Case-file types of the chapter whose families are not implemented yet
(Secs. 4.2.3-4.2.6). The loader rejects them with a clear error."""
from .base import Key, TypeDecl

TYPES = [
    TypeDecl("gear", "4.17, 4.18", (
        Key("i", "body"), Key("ri", "positive"), Key("j", "body"), Key("rj", "positive"),
        Key("carrier", "body", required=False), Key("internal", "bool", required=False),
        Key("phi0", "number", required=False)), None),
    TypeDecl("rack-pinion", "4.19, 4.20", (
        Key("pinion", "body"), Key("radius", "positive"), Key("center", "local", required=False, of="pinion"),
        Key("rack", "body"), Key("sj", "local", of="rack"), Key("u", "direction", required=False)), None),
    TypeDecl("cam-point", "4.26", (
        Key("cam", "body"), Key("outline", "outline"), Key("follower", "body"),
        Key("sj", "local", of="follower"), Key("theta", "number")), None),
    TypeDecl("cam-roller", "4.28", (
        Key("cam", "body"), Key("outline", "outline"), Key("follower", "body"),
        Key("sj", "local", of="follower"), Key("radius", "positive"), Key("theta", "number")), None),
    TypeDecl("cam-flat", "4.29", (
        Key("cam", "body"), Key("outline", "outline"), Key("follower", "body"),
        Key("sj", "local", of="follower"), Key("normal", "direction"), Key("theta", "number")), None),
    TypeDecl("point-follower", "4.30", (
        Key("i", "body"), Key("si", "local", of="i"), Key("j", "body"),
        Key("outline", "outline"), Key("theta", "number")), None),
]
