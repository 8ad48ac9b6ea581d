"""The environment variables rtrack reads (all of them steer compiled code), each checked as a
scenario field is: a value outside what is allowed is a :class:`SettingError` whose message
names the variable, what it holds and what is allowed (docs/reliability.md §11).

- ``RTRACK_CODEGEN``: ``1``/``true``/``yes``/``on`` or ``0``/``false``/``no``/``off`` (any
  case; default on) — whether compiled code is used;
- ``RTRACK_CACHE_DIR``: an absolute path (default ``$XDG_CACHE_HOME`` or ``~/.cache``, then
  ``/resilient_tracking/codegen``) — where compiled libraries are cached;
- ``RTRACK_CACHE_MAX_MB``: a number of megabytes from 0 to :data:`MAX_CACHE_MB` (default
  2048) — the cache's size limit.

A variable that is empty (``VAR=`` or an unset shell variable in ``VAR=$X``) counts as unset.
"""

from __future__ import annotations

import math
import os

#: Libraries kept in the cache beyond which the least recently used are deleted (MB).
DEFAULT_CACHE_MAX_MB = 2048.0
#: The largest cache limit accepted (MB, a petabyte): beyond it a typo, not a disk.
MAX_CACHE_MB = 1e9

_ON = ("1", "true", "yes", "on")
_OFF = ("0", "false", "no", "off")


class SettingError(ValueError):
    """An environment variable holds a value rtrack does not accept; the message is one line
    naming the variable and what is allowed."""


def _given(name: str) -> str:
    return os.environ.get(name, "").strip()


def _refuse(name: str, text: str, allowed: str) -> SettingError:
    return SettingError(f"{name}={text[:60]!r}: {allowed}")


def codegen_on() -> bool:
    """``RTRACK_CODEGEN``: whether compiled code may be used (default True)."""
    text = _given("RTRACK_CODEGEN")
    if not text or text.lower() in _ON:
        return True
    if text.lower() in _OFF:
        return False
    raise _refuse("RTRACK_CODEGEN", text, f"expected one of {', '.join(_ON + _OFF)}")


def cache_root() -> str | None:
    """``RTRACK_CACHE_DIR``: the cache folder the person chose (absolute), or None."""
    text = _given("RTRACK_CACHE_DIR")
    if not text:
        return None
    if not os.path.isabs(text):
        raise _refuse(
            "RTRACK_CACHE_DIR",
            text,
            "expected an absolute path (a relative one, or a '~' "
            "the shell did not expand, would make a cache in each working folder)",
        )
    return text


def cache_max_mb() -> float:
    """``RTRACK_CACHE_MAX_MB``: the cache's size limit in megabytes (default 2048)."""
    text = _given("RTRACK_CACHE_MAX_MB")
    if not text:
        return DEFAULT_CACHE_MAX_MB
    allowed = f"expected a number of megabytes from 0 to {MAX_CACHE_MB:g}"
    try:
        megabytes = float(text)
    except ValueError:
        raise _refuse("RTRACK_CACHE_MAX_MB", text, allowed) from None
    if not (math.isfinite(megabytes) and 0.0 <= megabytes <= MAX_CACHE_MB):
        raise _refuse("RTRACK_CACHE_MAX_MB", text, allowed)
    return megabytes


def check() -> None:
    """Raise :class:`SettingError` for the first variable holding a value not allowed."""
    codegen_on()
    cache_root()
    cache_max_mb()
