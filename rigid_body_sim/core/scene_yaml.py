"""The YAML reader of scene files: one document, YAML 1.2 scalars, bounded, iterative.

A scene file is read from PyYAML's event stream (``yaml.parse``, with LibYAML's C parser
when PyYAML has it) and built into plain Python values by the small loop below, instead of
``yaml.safe_load``, because a scene comes from users and a hostile or careless file must end
in a clear :class:`YamlReadError`, never a hang, a memory blow-up or a traceback:

- **Aliases are counted as what they expand to.** ``*a`` shares the anchored value (nothing
  is copied), but the document's expanded size and depth are added up while it is read, and
  a document past :data:`MAX_NODES` nodes or :data:`MAX_DEPTH` levels is refused at the
  event that crosses the limit (a 600-byte "billion laughs" file stops within a few thousand
  events). An alias to a collection that is still open (a recursive alias) is refused.
- **Nothing recurses**: nesting 10⁶ levels deep is refused at level :data:`MAX_DEPTH`.
- **YAML 1.2 core schema for plain scalars**: ``1e6``, ``1.0e6`` and ``.5`` are floats (YAML
  1.1, PyYAML's default, reads the first two as strings), ``0x1F`` and ``0o17`` integers,
  ``true``/``false`` booleans and ``~``/``null`` null; ``yes``, ``on``, ``1_000`` and
  ``1:30`` stay strings. Quoted scalars are always strings.
- **Tags**: only the core ones (``!!str``, ``!!int``, ``!!float``, ``!!bool``, ``!!null``,
  ``!!seq``, ``!!map``) and the non-specific ``!``; ``!!python/object``, ``!!binary``,
  ``!!set``, ``!!timestamp`` and local tags are refused.
- **Keys**: a key repeated in one mapping is an error naming both lines (PyYAML silently
  keeps the last); keys are scalars; ``<<`` merges a mapping or a list of mappings (its keys
  never override the mapping's own, the first mapping in the list wins).
- **Integers** of more than :data:`MAX_INTEGER_DIGITS` decimal digits are refused where they
  stand (Python refuses to convert 4,300 and more).

Errors carry the key path (``bodies.crate.mass``) and the line; the caller prefixes the file.

**JSON** is YAML too, and a scene in JSON reads the same either way. A document that starts
with ``{`` is first read by Python's json parser (C; about 20 times faster than the event
loop, which counts for 10⁵ bodies), but only when that is sure to give what the event loop
gives: within the limits by a count of brackets and separators (outside strings), no key twice
in an object, no integer past :data:`MAX_INTEGER_DIGITS` digits, no ``NaN``/``Infinity``
(strings to YAML). Anything else, and any text json refuses, is read by the event loop, whose
errors are the ones reported.
"""

from __future__ import annotations

import json
import re
from typing import Any

import numpy as np

__all__ = ["read_yaml", "YamlReadError", "key_text", "MAX_NODES", "MAX_DEPTH", "MAX_INTEGER_DIGITS"]

#: Most nodes (scalars and collections, aliases counted as what they expand to) a document may
#: expand to: what bounds the memory of what is read. 10⁵ bodies with a pose and a twist are
#: ~3·10⁶; a file of the largest size that is only tiny numbers (2 bytes a node) or an alias
#: that expands without limit is refused.
MAX_NODES = 10_000_000
#: Deepest nesting of collections, aliases expanded (a scene needs 6:
#: bodies → body → inertia → tensor → row).
MAX_DEPTH = 32
#: Longest decimal integer accepted, digits (anything longer is far past float64's 1.8e308).
MAX_INTEGER_DIGITS = 400

_CORE = "tag:yaml.org,2002:"
_NULL = re.compile(r"^(?:~|null|Null|NULL|)$")
_TRUE = re.compile(r"^(?:true|True|TRUE)$")
_FALSE = re.compile(r"^(?:false|False|FALSE)$")
_NUMBER = re.compile(r"[-+]?(?:(?P<int>[0-9]+)|(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?)")
_INT_OCT = re.compile(r"^0o[0-7]+$")
_INT_HEX = re.compile(r"^0x[0-9a-fA-F]+$")
_INF = re.compile(r"^([-+]?)\.(?:inf|Inf|INF)$")
_NAN = re.compile(r"^\.(?:nan|NaN|NAN)$")
#: First characters a plain scalar needs to be anything but a string (cheap pre-filter).
_NON_STRING_START = frozenset("0123456789+-.~nNtTfF")


class YamlReadError(ValueError):
    """A document that is not a readable scene: the message says where (key path, line) and why."""


def key_text(key: Any, limit: int = 64) -> str:
    """A mapping key as it appears in a key path: as written when short and printable; control
    characters escaped and long keys cut (so a 1 MB or escape-code key cannot flood or garble
    a message)."""
    if isinstance(key, str):
        head = key[:limit]
        text = head if head.isprintable() else repr(head)[1:-1]
        return text if len(key) <= limit else f"{text}...({len(key)} characters)"
    if isinstance(key, int) and not isinstance(key, bool) and key.bit_length() > 64:
        return f"<an integer of {len(str(abs(key))) if key.bit_length() < 13_000 else 'over 4,000'} digits>"
    if key is None or isinstance(key, (bool, int, float)):
        return str(key)
    return f"<{type(key).__name__}>"


class _Frame:
    """A collection being read: its value so far, what it expands to, and (mappings) the key."""

    __slots__ = ("is_map", "items", "anchor", "size", "depth", "key", "key_mark", "marks", "merges")

    def __init__(self, is_map: bool, anchor: str | None):
        self.is_map = is_map
        self.items: Any = {} if is_map else []
        self.anchor = anchor
        self.size = 1  # expanded nodes, itself included
        self.depth = 1  # expanded levels, itself included
        self.key: Any = _NO_KEY  # mapping: the key whose value comes next
        self.key_mark: Any = None
        self.marks: dict[Any, Any] = {}  # mapping: where each key was written
        self.merges: list[dict] = []  # mapping: values of << keys, in order


_NO_KEY = object()
_MERGE = object()


def _line(mark: Any) -> int:
    return mark.line + 1 if mark is not None else 0


class _Reader:
    """Builds the document from events; see the module docstring for the rules."""

    def __init__(self) -> None:
        self.stack: list[_Frame] = []
        self.anchors: dict[str, tuple[Any, int, int]] = {}  # name → (value, expanded size, depth)
        self.open_anchors: set[str] = set()
        self.result: Any = None

    # -------------------------------------------------------------- errors

    def path(self) -> str:
        """Key path of the node being read (``bodies.crate.mass``, ``wrenches[0]``)."""
        text = ""
        for frame in self.stack:
            if frame.is_map:
                if frame.key is _NO_KEY or frame.key is _MERGE:
                    continue
                part = key_text(frame.key)
                text = f"{text}.{part}" if text else part
            else:
                text = f"{text}[{len(frame.items)}]"
        return text

    def fail(self, mark: Any, message: str) -> None:
        where = self.path()
        line = f" (line {_line(mark)})" if mark is not None else ""
        raise YamlReadError(f"{where + ': ' if where else ''}{message}{line}")

    # -------------------------------------------------------------- events

    def read(self, get_event: Any) -> Any:
        """Consume events from ``get_event()`` (None at the end) and return the document."""
        from yaml.events import (
            AliasEvent,
            DocumentStartEvent,
            MappingEndEvent,
            MappingStartEvent,
            ScalarEvent,
            SequenceEndEvent,
            SequenceStartEvent,
        )

        stack = self.stack
        anchors = self.anchors
        add = self.add
        scalar = self.scalar
        resolve = self.resolve
        non_string = _NON_STRING_START
        documents = 0
        total = 0  # nodes so far, aliases expanded
        while True:
            event = get_event()
            if event is None:
                return self.result
            kind = type(event)
            if kind is ScalarEvent:
                if event.tag is None and event.implicit[0]:  # plain: YAML 1.2 core schema
                    value = event.value
                    if not value or value[0] in non_string:
                        value = resolve(value, event)
                else:
                    value = scalar(event)
                total += 1
                if total > MAX_NODES:
                    self.too_many(event)
                if event.anchor is not None:
                    anchors[event.anchor] = (value, 1, 0)
                if stack:
                    parent = stack[-1]
                    parent.size += 1
                    if not parent.is_map:
                        parent.items.append(value)
                    elif parent.key is _NO_KEY:  # a key: the common case inline (see add)
                        parent.key = _MERGE if value == "<<" and event.tag is None and event.implicit[0] else value
                        parent.key_mark = event.start_mark
                    else:
                        add(parent, value, event, False)
                else:
                    self.result = value
            elif kind is MappingStartEvent or kind is SequenceStartEvent:
                is_map = kind is MappingStartEvent
                if event.tag is not None:
                    self.check_collection_tag(event, is_map)
                total += 1
                if total > MAX_NODES:
                    self.too_many(event)
                if len(stack) >= MAX_DEPTH:
                    self.too_deep(event)
                stack.append(_Frame(is_map, event.anchor))
                if event.anchor is not None:
                    self.open_anchors.add(event.anchor)
            elif kind is MappingEndEvent or kind is SequenceEndEvent:
                frame = stack.pop()
                value = self.finish_mapping(frame) if frame.is_map else frame.items
                if frame.anchor is not None:
                    self.open_anchors.discard(frame.anchor)
                    anchors[frame.anchor] = (value, frame.size, frame.depth)
                self.place(value, frame.size, frame.depth, event)
            elif kind is AliasEvent:
                name = event.anchor
                if name in self.open_anchors:
                    self.fail(event.start_mark, f"expected an alias to a finished node, got *{key_text(name)} inside "
                                                "the node it names (a recursive alias)")
                if name not in anchors:
                    self.fail(event.start_mark, f"expected an alias to an anchor defined above, got *{key_text(name)}")
                value, size, depth = anchors[name]
                total += size
                if total > MAX_NODES:
                    self.too_many(event)
                if len(stack) + depth > MAX_DEPTH:
                    self.too_deep(event)
                self.place(value, size, depth, event)
            elif kind is DocumentStartEvent:
                documents += 1
                if documents > 1:
                    raise YamlReadError(f"expected one YAML document, got a second one (line {_line(event.start_mark)})")
            # StreamStart, StreamEnd, DocumentEnd: nothing to do.

    def too_many(self, event: Any) -> None:
        self.fail(event.start_mark, f"expected a document of at most {MAX_NODES:,} nodes with aliases expanded, got "
                                    "more (an alias that expands without limit?)")

    def too_deep(self, event: Any) -> None:
        self.fail(event.start_mark, f"expected nesting at most {MAX_DEPTH} levels deep with aliases expanded, got "
                                    "deeper (a scene needs 6)")

    def place(self, value: Any, size: int, depth: int, event: Any) -> None:
        """Put a finished collection or an alias's value (``size`` nodes, ``depth`` levels expanded)
        into the collection that holds it, or make it the document."""
        if not self.stack:
            self.result = value
            return
        parent = self.stack[-1]
        parent.size += size
        if depth >= parent.depth:
            parent.depth = depth + 1
        if parent.is_map:
            self.add(parent, value, event, False)
        else:
            parent.items.append(value)

    def add(self, parent: _Frame, value: Any, event: Any, is_merge_key: bool) -> None:
        """Put a finished node into the mapping ``parent``: as its next key, or as the value of its key."""
        if parent.key is _NO_KEY:
            if isinstance(value, (list, dict)):
                self.fail(event.start_mark, f"expected a name or number as a mapping key, got a {type(value).__name__}")
            parent.key = _MERGE if is_merge_key else value
            parent.key_mark = event.start_mark
            return
        key, parent.key = parent.key, _NO_KEY
        if key is _MERGE:
            merged = [value] if isinstance(value, dict) else value
            if not isinstance(merged, list) or not all(isinstance(m, dict) for m in merged):
                parent.key = _MERGE
                self.fail(event.start_mark, "expected a mapping or a list of mappings after '<<' (a merge key)")
            parent.merges.extend(merged)
            return
        if key in parent.marks:
            parent.key = key
            raise YamlReadError(
                f"{self.path()}: expected each key once per mapping, got {key_text(key)!r} again at line "
                f"{_line(parent.key_mark)} (first at line {_line(parent.marks[key])}); YAML would silently keep only "
                "the last")
        parent.marks[key] = parent.key_mark
        parent.items[key] = value

    @staticmethod
    def finish_mapping(frame: _Frame) -> dict:
        if not frame.merges:
            return frame.items
        out: dict = {}
        for merged in frame.merges:
            for key, value in merged.items():
                if key not in out:
                    out[key] = value
        out.update(frame.items)
        return out

    # -------------------------------------------------------------- scalars and tags

    def check_collection_tag(self, event: Any, is_map: bool) -> None:
        tag = event.tag
        if tag is None or tag == "!" or tag == _CORE + ("map" if is_map else "seq"):
            return
        self.fail(event.start_mark, f"expected a plain {'mapping' if is_map else 'list'}, got the tag {key_text(tag)} "
                        "(a scene holds numbers, strings, lists and mappings only)")

    def scalar(self, event: Any) -> Any:
        text: str = event.value
        tag = event.tag
        if tag is None:
            if not event.implicit[0]:  # quoted, or a block scalar: a string
                return text
            if not text or text[0] in _NON_STRING_START:
                return self.resolve(text, event)
            return text
        if tag == "!" or tag == _CORE + "str":
            return text
        if tag == _CORE + "null":
            if _NULL.match(text):
                return None
        elif tag == _CORE + "bool":
            if _TRUE.match(text) or _FALSE.match(text):
                return bool(_TRUE.match(text))
        elif tag == _CORE + "int":
            value = self.resolve(text, event)
            if isinstance(value, int) and not isinstance(value, bool):
                return value
        elif tag == _CORE + "float":
            value = self.resolve(text, event)
            if isinstance(value, (int, float)) and not isinstance(value, bool):
                try:
                    return float(value)
                except OverflowError:
                    return value  # an integer too large for a float: the scene reports it out of range
        else:
            self.fail(event.start_mark, f"expected a plain value, got the tag {key_text(tag)} (a scene holds numbers, strings, "
                            "lists and mappings only)")
        self.fail(event.start_mark, f"expected a value of the type its tag {key_text(tag)} names, got {key_text(text)!r}")
        raise AssertionError  # unreachable: fail raises

    def resolve(self, text: str, event: Any) -> Any:
        """A plain scalar under the YAML 1.2 core schema."""
        if not text or text[0] in _NON_STRING_START:
            number = _NUMBER.fullmatch(text)
            if number is not None:
                if number.group("int") is None:
                    return float(text)
                digits = len(number.group("int"))
                if digits > MAX_INTEGER_DIGITS:
                    self.fail(event.start_mark, f"expected a number, got an integer of {digits} digits (float64 holds "
                                                "up to about 1.8e308)")
                return int(text)
            if _NULL.match(text):
                return None
            if _TRUE.match(text):
                return True
            if _FALSE.match(text):
                return False
            match = _INF.match(text)
            if match:
                return float("-inf") if match.group(1) == "-" else float("inf")
            if _NAN.match(text):
                return float("nan")
            if _INT_HEX.match(text):
                return int(text[2:], 16)
            if _INT_OCT.match(text):
                return int(text[2:], 8)
        return text


def read_yaml(text: str) -> Any:
    """Read one YAML document into dicts, lists, strings, numbers, booleans and None.

    Parameters
    ----------
    text : str
        The document (already decoded; a leading byte-order mark is ignored).

    Returns
    -------
    The document's value; None for an empty document (or one of only comments).

    Raises
    ------
    YamlReadError
        Not YAML, more than one document, or past one of the limits (module docstring); the
        message names the key path and line where known.
    """
    if text.lstrip()[:1] == "{":
        value = _read_json(text)
        if value is not _NOT_JSON:
            return value
    import yaml  # deferred: only file loading needs it

    loader = (getattr(yaml, "CSafeLoader", None) or yaml.SafeLoader)(text)
    try:
        return _Reader().read(loader.get_event)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        where = f" at line {mark.line + 1}, column {mark.column + 1}" if mark is not None else ""
        what = "; ".join(" ".join(str(part).split()) for part in (exc.context, exc.problem) if part)
        raise YamlReadError(f"not valid YAML{where}: {what}{_tab_hint(text, mark)}") from None
    except yaml.reader.ReaderError as exc:
        line = text.count("\n", 0, exc.position) + 1
        raise YamlReadError(f"not valid YAML at line {line}: character #x{exc.character:04x}: {exc.reason}") from None
    except yaml.YAMLError as exc:
        raise YamlReadError("not valid YAML: " + " ".join(str(exc).split())) from None
    finally:
        loader.dispose()


def _tab_hint(text: str, mark: Any) -> str:
    """A hint when the parser stopped at a tab (YAML indents with spaces only)."""
    if mark is None:
        return ""
    lines = text.splitlines()
    if mark.line < len(lines) and "\t" in lines[mark.line][: mark.column + 1]:
        return " (YAML indents with spaces only: replace the tabs)"
    return ""


_NOT_JSON = object()
#: A JSON string literal (what the bracket count skips).
_JSON_STRING = re.compile(r'"(?:[^"\\]|\\.)*"')
_OPEN = np.zeros(256, dtype=np.int8)
_OPEN[[ord("["), ord("{")]] = 1
_OPEN[[ord("]"), ord("}")]] = -1


class _NotPlainJson(ValueError):
    """Raised inside json's hooks: the text needs the event loop (a repeated key, a long integer, NaN)."""


def _unique_keys(pairs: list[tuple[str, Any]]) -> dict:
    out = dict(pairs)
    if len(out) != len(pairs):
        raise _NotPlainJson("a key repeated in an object")
    return out


def _bounded_int(text: str) -> int:
    if len(text.lstrip("-")) > MAX_INTEGER_DIGITS:
        raise _NotPlainJson("a long integer")
    return int(text)


def _no_constant(text: str) -> Any:
    raise _NotPlainJson(text)


def _read_json(text: str) -> Any:
    """``text`` read as JSON when that gives exactly what the event loop would (module docstring); else _NOT_JSON."""
    bare = _JSON_STRING.sub('""', text)
    codes = np.frombuffer(bare.encode("utf-8", "surrogatepass"), dtype=np.uint8)
    steps = _OPEN[codes]
    depth = np.cumsum(steps[steps != 0], dtype=np.int64)  # nesting after each bracket
    if depth.size and int(depth.max()) > MAX_DEPTH:
        return _NOT_JSON
    # Every node but the first follows a ',' ':' '[' or '{' (keys counted as nodes, as the loop counts them).
    if bare.count(",") + bare.count(":") + bare.count("[") + bare.count("{") + 1 > MAX_NODES:
        return _NOT_JSON
    try:
        return json.loads(text, object_pairs_hook=_unique_keys, parse_int=_bounded_int, parse_constant=_no_constant)
    except (ValueError, RecursionError):  # json.JSONDecodeError and _NotPlainJson are ValueErrors
        return _NOT_JSON
