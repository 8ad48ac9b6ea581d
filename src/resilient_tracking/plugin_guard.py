"""Plug-in code that exits or raises past ``except Exception`` becomes an error naming it.

A plug-in (a policy, target motion, hazard model, sensor or guard from outside this package, a
learned policy's function) runs in rtrack's own process. ``sys.exit(0)`` in it would end a
command with status 0 and nothing written, and a ``GeneratorExit`` or another
``BaseException`` that is not an ``Exception`` would pass every ``except Exception`` and end
it with a traceback. Where plug-in code is imported or a run is driven, :func:`contained`
turns such an exception into :class:`PluginError`, an ordinary exception whose one-line message
says which code did what: ``plug-in mypkg.policy.Greedy.act (/…/policy.py, line 12) called
sys.exit(0) while running``. Ctrl-C and SIGTERM (:mod:`~resilient_tracking.interrupts`) pass
through unchanged.

:func:`importing` imports a plug-in module with a command line of its own
(``sys.argv = [its file]``), so a module that parses arguments at import never takes rtrack's
for its own, and keeps what the import prints, to quote its last line if the import fails.
"""

from __future__ import annotations

import contextlib
import importlib
import importlib.util
import io
import sys
import sysconfig
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType, TracebackType

from resilient_tracking import interrupts

_PATHS = sysconfig.get_paths()
#: This package's folder: its code is no plug-in's.
_OURS = Path(__file__).resolve().parent
#: The standard library's folders (its code is no plug-in's) and the installed packages'
#: (which may lie inside them, and whose code may be a plug-in's).
_STDLIB = tuple({Path(_PATHS[k]).resolve() for k in ("stdlib", "platstdlib")})
_INSTALLED = tuple({Path(_PATHS[k]).resolve() for k in ("purelib", "platlib")})


class PluginError(RuntimeError):
    """A plug-in exited (``sys.exit``) or raised a ``BaseException`` that is not an
    ``Exception`` nor an interrupt; the message names the code and what it did."""


def is_escape(err: BaseException) -> bool:
    """Whether ``err`` passes ``except Exception`` and is no interrupt: ``SystemExit``,
    ``GeneratorExit`` or another ``BaseException`` subclass."""
    return not isinstance(err, Exception | KeyboardInterrupt | interrupts.Terminated)


def is_failure(err: BaseException) -> bool:
    """Whether ``err`` is a failure to report (an ``Exception`` or an escape), not an
    interrupt."""
    return not isinstance(err, KeyboardInterrupt | interrupts.Terminated)


def what_it_did(err: BaseException, when: str = "") -> str:
    """``called sys.exit(0) at import`` or ``raised GeneratorExit while running: why``
    (``when`` says at what, its message comes last)."""
    at = f" {when}" if when else ""
    if isinstance(err, SystemExit):
        return f"called sys.exit({err.code!r}){at}"
    text = str(err)
    return f"raised {type(err).__name__}{at}" + (f": {text}" if text else "")


@dataclass(frozen=True)
class Culprit:
    """The code an exception came from: its module, function (``Class.method``; ``<module>``
    for code run at import), file and line."""

    module: str
    function: str
    file: str
    line: int

    def __str__(self) -> str:
        name = self.module if self.function == "<module>" else f"{self.module}.{self.function}"
        return f"{name} ({self.file}, line {self.line})"


def culprit(tb: TracebackType | None) -> Culprit | None:
    """The innermost frame of ``tb`` whose code is neither this package's nor the standard
    library's (a plug-in's); the innermost frame of all when there is none; ``None`` for no
    traceback."""
    frames = []
    while tb is not None:
        frames.append((tb.tb_frame, tb.tb_lineno))
        tb = tb.tb_next
    if not frames:
        return None
    chosen = next((f for f in reversed(frames) if _is_plugin_code(f[0].f_code.co_filename)), None)
    frame, line = chosen or frames[-1]
    module = frame.f_globals.get("__name__")
    return Culprit(
        module if isinstance(module, str) else "?",
        frame.f_code.co_qualname,
        frame.f_code.co_filename,
        line,
    )


def _is_plugin_code(filename: str) -> bool:
    """Whether ``filename`` holds code neither this package's nor the standard library's."""
    if filename.startswith("<"):  # <frozen importlib._bootstrap>, <string>
        return False
    try:
        path = Path(filename).resolve()
    except (OSError, RuntimeError):
        return True
    if path.is_relative_to(_OURS):
        return False
    if any(path.is_relative_to(root) for root in _INSTALLED):
        return True
    return not any(path.is_relative_to(root) for root in _STDLIB)


def describe(err: BaseException, when: str) -> str:
    """One line: which plug-in code did what ``when`` (``at import``, ``while running``)."""
    found = culprit(err.__traceback__)
    who = f"plug-in {found}" if found is not None else "a plug-in"
    return f"{who} {what_it_did(err, when)}"


def contained(when: str) -> _Contained:
    """``with contained("while running"):`` — an escape (:func:`is_escape`) inside becomes
    :class:`PluginError` (:func:`describe`); exceptions and interrupts pass unchanged."""
    return _Contained(when)


class _Contained:
    """The context manager of :func:`contained` (a class: an escape may be ``GeneratorExit``,
    which a generator-based one would receive as its own)."""

    def __init__(self, when: str):
        self.when = when

    def __enter__(self) -> None:
        return None

    def __exit__(
        self,
        kind: type[BaseException] | None,
        err: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        if err is not None and is_escape(err):
            raise PluginError(describe(err, self.when)) from err


@contextlib.contextmanager
def _own_command_line(name: str) -> Iterator[None]:
    """``sys.argv`` is ``[name]`` inside (restored after, whatever the code did to it)."""
    saved = sys.argv
    sys.argv = [name]
    try:
        yield
    finally:
        sys.argv = saved


def importing(module_name: str) -> ModuleType:
    """Import the plug-in module ``module_name`` with ``sys.argv = [its file]`` and what it
    prints held back: printed after a successful import, quoted (its last line) in the
    :class:`PluginError` of an import that exits. Exceptions pass unchanged."""
    out, err = io.StringIO(), io.StringIO()
    try:
        with (
            _own_command_line(module_name),
            contextlib.redirect_stdout(out),
            contextlib.redirect_stderr(err),
        ):
            spec = importlib.util.find_spec(module_name)  # imports the parent packages
            if spec is not None and spec.origin:
                sys.argv = [spec.origin]
            module = importlib.import_module(module_name)
    except BaseException as raised:
        if not is_escape(raised):
            _pass_on(out, err)
            raise
        printed = _last_line(err.getvalue()) or _last_line(out.getvalue())
        said = f"; it printed: {printed}" if printed else ""
        raise PluginError(describe(raised, "at import") + said) from raised
    _pass_on(out, err)
    return module


def _pass_on(out: io.StringIO, err: io.StringIO) -> None:
    """Print what an import printed, where it meant to."""
    sys.stdout.write(out.getvalue())
    sys.stderr.write(err.getvalue())


def _last_line(text: str) -> str:
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    return lines[-1][:200] if lines else ""
