"""Plain CDR (XCDR1, little-endian) encoding and decoding of the nodes' messages, made fast.

cyclonedds' Python serializer interprets every message field by field: about 50 µs to encode
or decode a ``PoseStamped`` and 20 ms to encode the belief ``MarkerArray`` of a 40-robot team,
which a free-running node at 10 Hz pays on its control path (60 poses in, 40 setpoints out
each tick) or, for the markers, in a thread that holds the interpreter lock. A :class:`Codec`
is made once per message type from the same IDL annotations and reads or writes each run of
fixed-size fields with one ``struct`` call; it gives the bytes cyclonedds gives
(``tests/test_ros2_cdr.py`` compares both for every message type of :mod:`~.msgs`), so peers
see no difference. The message types use it through ``serialize`` and ``deserialize``.

XCDR1 in brief: a 4-byte encapsulation header (``00 01 00 00``: plain CDR, little-endian),
then the fields in order, each primitive aligned to its size (at most 8) counted from the end
of the header; a string is its length with the terminating NUL (uint32), its bytes and the NUL;
a sequence its count (uint32) then its elements; a fixed array its elements alone.
"""

from __future__ import annotations

import dataclasses
import struct
import typing
from collections.abc import Callable
from operator import attrgetter
from typing import Any

from cyclonedds.idl import IdlStruct
from cyclonedds.idl._support import Endianness
from cyclonedds.idl.types import array, sequence

#: struct codes and sizes of the IDL primitives (``bool`` travels as one byte)
_PRIMITIVES = {
    "float64": "d",
    "float32": "f",
    "int64": "q",
    "uint64": "Q",
    "int32": "i",
    "uint32": "I",
    "int16": "h",
    "uint16": "H",
    "int8": "b",
    "uint8": "B",
    "bool": "?",
}
HEADER = b"\x00\x01\x00\x00"
_COUNT = struct.Struct("<I")


def _primitive(hint: Any) -> str | None:
    """The struct code of a primitive field's annotation, else None."""
    if hint is bool:
        return "?"
    if typing.get_origin(hint) is typing.Annotated:
        meta = typing.get_args(hint)[1]
        if isinstance(meta, str):
            return _PRIMITIVES.get(meta)
    return None


def _container(hint: Any) -> sequence | array | None:
    """The ``sequence`` or ``array`` of a field's annotation, else None."""
    if typing.get_origin(hint) is typing.Annotated:
        meta = typing.get_args(hint)[1]
        if isinstance(meta, sequence | array):
            return meta
    return None


def _run_format(codes: list[str], offset: int) -> struct.Struct:
    """A struct for primitives ``codes`` written from data offset ``offset`` (mod 8): each
    aligned to its size with pad bytes."""
    parts = []
    for code in codes:
        size = struct.calcsize(code)
        pad = -offset % size
        parts.append("x" * pad + code)
        offset += pad + size
    return struct.Struct("<" + "".join(parts))


class _Run:
    """Consecutive primitive fields, written or read with one struct per start offset mod 8."""

    def __init__(self, codes: list[str]):
        self.codes = codes
        self._formats = [_run_format(codes, start) for start in range(8)]

    def format(self, offset: int) -> struct.Struct:
        return self._formats[offset % 8]


Writer = Callable[[bytearray, Any], None]
Reader = Callable[[memoryview, int], tuple[Any, int]]


def _align(out: bytearray, size: int) -> None:
    out.extend(b"\0" * (-(len(out) - 4) % size))


def _write_string(out: bytearray, value: str) -> None:
    data = value.encode()
    _align(out, 4)
    out.extend(_COUNT.pack(len(data) + 1))
    out.extend(data)
    out.append(0)


def _read_string(buf: memoryview, pos: int) -> tuple[str, int]:
    pos += -(pos - 4) % 4
    (length,) = _COUNT.unpack_from(buf, pos)
    pos += 4
    return bytes(buf[pos : pos + length - 1]).decode(), pos + length


class Codec:
    """Encoder and decoder of one message type (an ``IdlStruct`` dataclass)."""

    def __init__(self, cls: type[IdlStruct]):
        self.cls = cls
        hints = typing.get_type_hints(cls, include_extras=True)
        self._fields = [(f.name, hints[f.name]) for f in dataclasses.fields(cls)]  # type: ignore[arg-type]
        self._writers: list[Writer] = []
        self._readers: list[tuple[list[str], Reader]] = []
        self._compile()

    # ------------------------------------------------------------------ making

    def _compile(self) -> None:
        # writing: nested structs flattened, so that a run may span them (a Pose is 7 doubles)
        leaves: list[tuple[str, Any]] = []
        self._flatten("", self.cls, leaves)
        run: list[tuple[str, str]] = []
        for path, kind in leaves:
            if isinstance(kind, str):
                run.append((path, kind))
                continue
            if run:
                self._writers.append(_run_writer(run))
                run = []
            self._writers.append(_writer(path, kind))
        if run:
            self._writers.append(_run_writer(run))
        # reading: struct by struct (each becomes an object), runs within one struct
        names: list[str] = []
        codes: list[str] = []
        for name, hint in self._fields:
            code = _primitive(hint)
            if code is not None:
                names.append(name)
                codes.append(code)
                continue
            if codes:
                self._readers.append((names, _run_reader(_Run(codes))))
                names, codes = [], []
            self._readers.append(([name], _reader(hint)))
        if codes:
            self._readers.append((names, _run_reader(_Run(codes))))

    def _flatten(self, prefix: str, cls: type, leaves: list[tuple[str, Any]]) -> None:
        hints = typing.get_type_hints(cls, include_extras=True)
        for f in dataclasses.fields(cls):
            path, hint = prefix + f.name, hints[f.name]
            code = _primitive(hint)
            if code is not None:
                leaves.append((path, code))
            elif isinstance(hint, type) and issubclass(hint, IdlStruct):
                self._flatten(path + ".", hint, leaves)
            else:
                leaves.append((path, hint))

    # ------------------------------------------------------------------ use

    def encode(self, msg: Any) -> bytes:
        """The message's bytes, header included (as ``IdlStruct.serialize`` gives them)."""
        out = bytearray(HEADER)
        self.write(out, msg)
        return bytes(out)

    def write(self, out: bytearray, msg: Any) -> None:
        """Append the message's fields to ``out`` (which starts with the header)."""
        for write in self._writers:
            write(out, msg)

    def decode(self, data: bytes) -> Any:
        """The message of ``data`` (header included); only plain little-endian CDR."""
        if bytes(data[:2]) != HEADER[:2]:
            raise ValueError(f"{self.cls.__name__}: not plain little-endian CDR")
        return self.read(memoryview(data), 4)[0]

    def read(self, buf: memoryview, pos: int) -> tuple[Any, int]:
        """The message whose fields start at ``pos`` of ``buf``, and where they end."""
        values: dict[str, Any] = {}
        for names, read in self._readers:
            value, pos = read(buf, pos)
            if len(names) == 1 and not isinstance(value, tuple):
                values[names[0]] = value
            else:
                values.update(zip(names, value, strict=True))
        return self.cls(**values), pos


_CODECS: dict[type, Codec] = {}


def codec(cls: type[IdlStruct]) -> Codec:
    """The (cached) codec of a message type."""
    found = _CODECS.get(cls)
    if found is None:
        found = _CODECS[cls] = Codec(cls)
    return found


def _run_writer(run: list[tuple[str, str]]) -> Writer:
    fields = _Run([code for _, code in run])
    get = attrgetter(*(path for path, _ in run))
    single = len(run) == 1

    def write(out: bytearray, msg: Any) -> None:
        values = (get(msg),) if single else get(msg)
        out.extend(fields.format(len(out) - 4).pack(*values))

    return write


def _element_writer(hint: Any) -> Callable[[bytearray, Any], None]:
    """Writes one element (or a whole primitive sequence, see :func:`_writer`)."""
    if hint is str:
        return _write_string
    if isinstance(hint, type) and issubclass(hint, IdlStruct):
        return lambda out, value: codec(hint).write(out, value)
    raise TypeError(f"cdr: unsupported field type {hint!r}")


def _writer(path: str, hint: Any) -> Writer:
    get = attrgetter(path)
    if hint is str:
        return lambda out, msg: _write_string(out, get(msg))
    box = _container(hint)
    if box is None:
        raise TypeError(f"cdr: unsupported field type {hint!r} of {path}")
    counted = isinstance(box, sequence)
    code = _primitive(box.subtype)
    if code is not None:
        size = struct.calcsize(code)

        def write_primitives(out: bytearray, msg: Any) -> None:
            values = get(msg)
            if counted:
                _align(out, 4)
                out.extend(_COUNT.pack(len(values)))
            if len(values):
                _align(out, size)
                out.extend(struct.pack(f"<{len(values)}{code}", *values))

        return write_primitives
    element = _element_writer(box.subtype)

    def write_elements(out: bytearray, msg: Any) -> None:
        values = get(msg)
        if counted:
            _align(out, 4)
            out.extend(_COUNT.pack(len(values)))
        for value in values:
            element(out, value)

    return write_elements


def _run_reader(run: _Run) -> Reader:
    def read(buf: memoryview, pos: int) -> tuple[Any, int]:
        fmt = run.format(pos - 4)
        values = fmt.unpack_from(buf, pos)
        return (values[0] if len(run.codes) == 1 else values), pos + fmt.size

    return read


def _reader(hint: Any) -> Reader:
    if hint is str:
        return _read_string
    if isinstance(hint, type) and issubclass(hint, IdlStruct):
        return lambda buf, pos: codec(hint).read(buf, pos)
    box = _container(hint)
    if box is None:
        raise TypeError(f"cdr: unsupported field type {hint!r}")
    counted = isinstance(box, sequence)
    length = 0 if isinstance(box, sequence) else box.length
    code = _primitive(box.subtype)
    element = None if code is not None else _reader(box.subtype)

    def read(buf: memoryview, pos: int) -> tuple[Any, int]:
        if counted:
            pos += -(pos - 4) % 4
            (n,) = _COUNT.unpack_from(buf, pos)
            pos += 4
        else:
            n = length
        if code is not None:
            if not n:
                return [], pos
            size = struct.calcsize(code)
            pos += -(pos - 4) % size
            values = list(struct.unpack_from(f"<{n}{code}", buf, pos))
            return values, pos + n * size
        out = []
        for _ in range(n):
            assert element is not None
            value, pos = element(buf, pos)
            out.append(value)
        return out, pos

    return read


_T = typing.TypeVar("_T", bound=type)


def fast_cdr(cls: _T) -> _T:
    """Class decorator of a message type: its ``serialize`` and ``deserialize`` (what the DDS
    writers and readers call) use its :class:`Codec` for plain little-endian CDR, and
    cyclonedds' serializer for anything else (XCDR2, a caller's buffer or byte order)."""

    def serialize(
        self: Any, buffer: Any = None, endianness: Any = None, use_version_2: bool | None = None
    ) -> bytes:
        """The message as CDR bytes, header included (what the DDS writer sends)."""
        if buffer is None and endianness in (None, Endianness.Little) and not use_version_2:
            return codec(cls).encode(self)
        return IdlStruct.serialize(self, buffer, endianness, use_version_2)

    def deserialize(
        klass: Any, data: bytes, has_header: bool = True, use_version_2: bool | None = None
    ) -> Any:
        """The message of CDR bytes ``data`` (what the DDS reader received)."""
        if has_header and use_version_2 is None and bytes(data[:2]) == HEADER[:2]:
            return codec(klass).decode(data)
        return klass.__idl__.deserialize(data, has_header=has_header, use_version_2=use_version_2)

    cls.serialize = serialize  # type: ignore[attr-defined]
    cls.deserialize = classmethod(deserialize)  # type: ignore[attr-defined]
    return cls
