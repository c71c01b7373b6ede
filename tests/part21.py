"""A second STEP reader for the tests (issue 31): a strict ISO 10303-21 syntax
and reference check that shares nothing with OCCT.

It reads the exchange structure the way the standard's grammar (clauses 5-10
of ISO 10303-21) lays it out -- ``ISO-10303-21;``, a HEADER section of three
or more records, one or more DATA sections of entity instances, and
``END-ISO-10303-21;`` -- and checks what a reader other than OCCT relies on:

- every token is one the standard defines (keywords, instance names ``#n``,
  integers, reals with their decimal point, strings with doubled apostrophes
  and only printable characters (line breaks, which a reader ignores, aside),
  enumerations ``.X.``, binaries, ``$``, ``*``), comments ``/* */`` anywhere between tokens;
- records are well formed: ``#n = NAME ( parameters ) ;`` or a complex
  instance ``#n = ( NAME ( … ) NAME ( … ) … ) ;``, parentheses balanced, lists
  and typed parameters (``LENGTH_MEASURE(1.)``) nested to any depth;
- instance names are unique, and every reference names an instance of the file.

It does not know any schema: it checks the file, not what its entities mean.
(``steputils`` 0.1, the one maintained-looking pure-Python Part 21 parser on the
registry, reads these files too but takes about 5 s for a 2 MB file and does
not check references, so the tests carry this one.)
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

_TOKEN = re.compile(
    rb"""
    (?P<ws>[ \t\r\n]+|/\*.*?\*/)
  | (?P<name>\#[0-9]+)
  | (?P<const>@[A-Za-z_][A-Za-z0-9_]*)
  | (?P<real>[+-]?[0-9]+\.[0-9]*(?:[Ee][+-]?[0-9]+)?)
  | (?P<int>[+-]?[0-9]+)
  | (?P<str>'(?:[^'\\]|''|\\\\|\\S\\.|\\P[A-I]\\|\\X\\[0-9A-F]{2}
        |\\X2\\(?:[0-9A-F]{4})+\\X0\\|\\X4\\(?:[0-9A-F]{8})+\\X0\\)*')
  | (?P<enum>\.[A-Za-z_][A-Za-z0-9_]*\.)
  | (?P<bin>"[0-3][0-9A-Fa-f]*")
  | (?P<magic>(?:END-)?ISO-10303-21)
  | (?P<kw>!?[A-Za-z_][A-Za-z0-9_]*)
  | (?P<punct>[(),=;$*])
    """,
    re.VERBOSE | re.DOTALL,
)
_PRINTABLE = re.compile(rb"^[\x20-\x7e\r\n]*$")  # line breaks are ignored, even in strings


class Part21Error(ValueError):
    """The file breaks the Part 21 grammar or names an instance it lacks."""


@dataclass
class Exchange:
    """What the check read: the header records and the instances' entity names."""

    header: list[str] = field(default_factory=list)
    entities: dict[int, list[str]] = field(default_factory=dict)
    references: int = 0


def _tokens(data: bytes) -> list[tuple[str, bytes, int]]:
    out = []
    pos, n = 0, len(data)
    while pos < n:
        m = _TOKEN.match(data, pos)
        if m is None:
            raise Part21Error(f"byte {pos}: no token starts with {data[pos : pos + 20]!r}")
        kind = m.lastgroup
        assert kind is not None
        if kind != "ws":
            text = m.group()
            if kind == "str" and not _PRINTABLE.match(text):
                raise Part21Error(f"byte {pos}: string with a non-printable byte")
            if kind == "punct":
                kind = text.decode()
            out.append((kind, text, pos))
        pos = m.end()
    return out


class _Parser:
    def __init__(self, toks: list[tuple[str, bytes, int]]):
        self.t = toks
        self.i = 0
        self.refs: list[tuple[int, int]] = []  # (instance named, byte offset)

    def peek(self) -> str:
        return self.t[self.i][0] if self.i < len(self.t) else "eof"

    def take(self, kind: str, text: bytes | None = None) -> bytes:
        if self.i >= len(self.t):
            raise Part21Error(f"end of file where {kind} {text or b''!r} was due")
        k, v, pos = self.t[self.i]
        if k != kind or (text is not None and v != text):
            raise Part21Error(f"byte {pos}: {v[:30]!r} where {kind} {text or b''!r} was due")
        self.i += 1
        return v

    def parameter(self) -> None:
        k = self.peek()
        if k == "(":
            self.plist()
        elif k == "kw":  # a typed parameter: KEYWORD ( parameter )
            self.take("kw")
            self.take("(")
            self.parameter()
            self.take(")")
        elif k == "name":
            _, v, pos = self.t[self.i]
            self.refs.append((int(v[1:]), pos))
            self.i += 1
        elif k in ("real", "int", "str", "enum", "bin", "$", "*", "const"):
            self.i += 1
        else:
            pos = self.t[self.i][2] if self.i < len(self.t) else -1
            raise Part21Error(f"byte {pos}: {k} is not a parameter")

    def plist(self) -> None:
        """``( )`` or ``( p , p , … )``."""
        self.take("(")
        if self.peek() == ")":
            self.i += 1
            return
        self.parameter()
        while self.peek() == ",":
            self.i += 1
            self.parameter()
        self.take(")")

    def record(self) -> str:
        name = self.take("kw")  # "!NAME" is a user-defined entity
        self.plist()
        return name.decode()


def read(data: bytes) -> Exchange:
    """Check ``data`` as a Part 21 exchange structure; raise :class:`Part21Error`."""
    p = _Parser(_tokens(data))
    out = Exchange()
    p.take("magic", b"ISO-10303-21")
    p.take(";")
    p.take("kw", b"HEADER")
    p.take(";")
    while p.peek() == "kw" and p.t[p.i][1] != b"ENDSEC":
        out.header.append(p.record())
        p.take(";")
    p.take("kw", b"ENDSEC")
    p.take(";")
    if out.header[:3] != ["FILE_DESCRIPTION", "FILE_NAME", "FILE_SCHEMA"]:
        raise Part21Error(f"header records {out.header[:3]}, not the three the standard requires")
    sections = 0
    while p.peek() == "kw" and p.t[p.i][1] == b"DATA":
        sections += 1
        p.take("kw", b"DATA")
        if p.peek() == "(":  # DATA ( name , ( schema ) ) ; of edition 3
            p.plist()
        p.take(";")
        while p.peek() == "name":
            _, v, pos = p.t[p.i]
            p.i += 1
            n = int(v[1:])
            if n in out.entities:
                raise Part21Error(f"byte {pos}: #{n} defined twice")
            p.take("=")
            if p.peek() == "(":  # a complex instance: ( A(...) B(...) ... )
                p.take("(")
                names = [p.record()]
                while p.peek() == "kw":
                    names.append(p.record())
                p.take(")")
            else:
                names = [p.record()]
            p.take(";")
            out.entities[n] = names
        p.take("kw", b"ENDSEC")
        p.take(";")
    if not sections:
        raise Part21Error("no DATA section")
    p.take("magic", b"END-ISO-10303-21")
    p.take(";")
    if p.i != len(p.t):
        raise Part21Error(f"byte {p.t[p.i][2]}: tokens after END-ISO-10303-21")
    for n, pos in p.refs:
        if n not in out.entities:
            raise Part21Error(f"byte {pos}: #{n} is referenced but never defined")
    out.references = len(p.refs)
    return out


def read_file(path: Path) -> Exchange:
    return read(Path(path).read_bytes())
