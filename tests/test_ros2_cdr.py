"""The fast CDR codec gives cyclonedds' own bytes, and reads them back, for every message type."""

from __future__ import annotations

import dataclasses
import typing

import numpy as np
import pytest

pytest.importorskip("cyclonedds")

from cyclonedds.idl import IdlStruct  # noqa: E402

from resilient_tracking.ros2 import msgs  # noqa: E402
from resilient_tracking.ros2.cdr import _container, _primitive, codec  # noqa: E402

_INTS = {"i": (-(2**31), 2**31), "I": (0, 2**32), "B": (0, 256), "b": (-128, 128)}


def random_message(cls: type, rng: np.random.Generator) -> typing.Any:
    """An instance of ``cls`` with every field drawn: odd lengths, empty sequences, unicode."""
    hints = typing.get_type_hints(cls, include_extras=True)
    return cls(**{f.name: _value(hints[f.name], rng) for f in dataclasses.fields(cls)})


def _value(hint: typing.Any, rng: np.random.Generator) -> typing.Any:
    code = _primitive(hint)
    if code is not None:
        return _scalar(code, rng)
    if hint is str:
        return "".join(rng.choice(list("abcxyz_/é✓"), size=int(rng.integers(0, 7))))
    if isinstance(hint, type) and issubclass(hint, IdlStruct):
        return random_message(hint, rng)
    box = _container(hint)
    assert box is not None, hint
    n = box.length if hasattr(box, "length") else int(rng.integers(0, 4))
    return [_value(box.subtype, rng) for _ in range(n)]


def _scalar(code: str, rng: np.random.Generator) -> typing.Any:
    if code == "?":
        return bool(rng.integers(2))
    if code == "d":
        return float(rng.normal() * 10.0 ** rng.integers(-3, 4))
    if code == "f":
        return float(np.float32(rng.normal()))
    low, high = _INTS[code]
    return int(rng.integers(low, high))


@pytest.mark.parametrize("name", sorted(msgs.MESSAGE_TYPES))
def test_the_codec_gives_cyclonedds_bytes_and_reads_them(name: str) -> None:
    cls = msgs.MESSAGE_TYPES[name]
    rng = np.random.default_rng(len(name))
    for _ in range(25):
        msg = random_message(cls, rng)
        reference = IdlStruct.serialize(msg)  # cyclonedds' own serializer
        assert codec(cls).encode(msg) == reference
        assert msg.serialize() == reference  # what the DDS writer calls
        assert codec(cls).decode(reference) == IdlStruct.deserialize.__func__(cls, reference)
        assert cls.deserialize(reference) == msg


def test_big_endian_data_is_refused_by_the_fast_decoder() -> None:
    big = b"\x00\x00\x00\x00" + bytes(72)
    with pytest.raises(ValueError, match="little-endian"):
        codec(msgs.PoseStamped).decode(big)
