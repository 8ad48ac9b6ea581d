"""Find plug-ins by name: policies, hazard models and target motions.

A :class:`Registry` maps names to classes. A name is found, in this order, among

1. the classes registered in this process (the built-ins register themselves with
   :meth:`Registry.register` when their module is imported);
2. the entry points of the registry's group, declared by installed packages in their
   ``pyproject.toml``::

       [project.entry-points."resilient_tracking.policies"]
       greedy = "greedy_tracker.policy:GreedyPolicy"

3. a dotted path ``package.module:Class``, imported on demand.

A registered class that takes an argument (its ``argument`` names the parameter it fills, as the
``onnx`` policy's model file) is also found as ``name:ARGUMENT`` (``onnx:team.onnx``): the class
made by its ``with_argument(ARGUMENT)``. A registered name wins over a module of the same name.

So a new policy, hazard model or target motion is one new file in its own package: nothing in
this package changes. Lookups raise :class:`UnknownName`, whose message lists what is known.
A plug-in module is imported with a command line of its own, and one that exits or raises
anything but an interrupt at import is an :class:`UnknownName` saying what it did
(:mod:`~resilient_tracking.plugin_guard`).
"""

from __future__ import annotations

import importlib
import logging
from collections.abc import Callable
from importlib.metadata import entry_points
from typing import Any, Generic, TypeVar

from resilient_tracking import plugin_guard

log = logging.getLogger(__name__)

T = TypeVar("T", bound=type)


class UnknownName(LookupError):
    """A name no registry entry, entry point or importable ``module:Class`` path matches."""

    def __str__(self) -> str:  # LookupError would quote the message
        return str(self.args[0])


class Registry(Generic[T]):
    """Classes of one kind (``kind`` names it in messages) found by name.

    ``group`` is the entry-point group other packages register in; ``builtins`` are modules of
    this package imported before the first lookup, so that their classes have registered.
    ``base`` is the class every entry must subclass.
    """

    def __init__(self, kind: str, group: str, base: type, builtins: tuple[str, ...] = ()):
        self.kind = kind
        self.group = group
        self.base = base
        self._builtins = builtins
        self._entries: dict[str, T] = {}
        #: classes of names ``name:ARGUMENT``, made once each
        self._bound: dict[str, T] = {}
        self._loaded = False
        self._entry_point_names: set[str] | None = None

    def register(self, name: str) -> Callable[[T], T]:
        """Class decorator: ``@POLICIES.register("greedy")`` makes the class findable by name."""

        def add(cls: T) -> T:
            known = self._entries.get(name)
            if known is not None and known is not cls:
                raise ValueError(f"{self.kind} {name!r} is already registered as {known!r}")
            self._check(cls, name)
            self._entries[name] = cls
            return cls

        return add

    def get(self, name: str) -> T:
        """The class called ``name``: registered, an entry point, or ``package.module:Class``."""
        self._load_builtins()
        if name in self._entries:
            return self._entries[name]
        if ":" in name:
            return self._with_argument(name) or self._import(name)
        for ep in entry_points(group=self.group):
            if ep.name == name:
                try:
                    plugin_guard.importing(ep.module)
                    cls = ep.load()
                except plugin_guard.PluginError as err:
                    raise UnknownName(
                        f"{self.kind} {name!r}: entry point {ep.value!r}: {err}"
                    ) from None
                except Exception as err:  # a broken plug-in is named, never a traceback
                    raise UnknownName(
                        f"{self.kind} {name!r}: entry point {ep.value!r} failed to load "
                        f"({type(err).__name__}: {err})"
                    ) from None
                self._check(cls, name)
                self._entries.setdefault(name, cls)
                return cls
        raise UnknownName(
            f"unknown {self.kind} {name!r}; choose from {', '.join(self.names())} "
            "or give a class as package.module:Class"
        )

    def problem(self, name: str) -> str | None:
        """Why ``name`` names no class here (the :class:`UnknownName` message), else ``None``."""
        try:
            self.get(name)
        except UnknownName as err:
            return str(err)
        return None

    def names(self) -> list[str]:
        """Registered names and entry-point names, sorted (dotted paths are not listed); the
        installed packages' entry points are read once per process."""
        self._load_builtins()
        if self._entry_point_names is None:
            self._entry_point_names = {ep.name for ep in entry_points(group=self.group)}
        return sorted(set(self._entries) | self._entry_point_names)

    def builtin_names(self) -> list[str]:
        """Names registered by this package's own modules, in the order of the ``builtins``
        modules (whichever was imported first), then in registration order."""
        self._load_builtins()
        ours = [n for n, cls in self._entries.items() if _is_ours(cls)]
        return sorted(ours, key=lambda n: self._builtin_rank(self._entries[n]))

    def _builtin_rank(self, cls: type) -> int:
        """The index of the ``builtins`` module (or package) that holds ``cls``."""
        module = cls.__module__
        for rank, name in enumerate(self._builtins):
            if module == name or module.startswith(name + "."):
                return rank
        return len(self._builtins)

    # ------------------------------------------------------------------ internals

    def _load_builtins(self) -> None:
        if not self._loaded:
            self._loaded = True
            for module in self._builtins:
                importlib.import_module(module)

    def _with_argument(self, name: str) -> T | None:
        """The class of ``name:ARGUMENT`` when ``name`` is registered and takes an argument."""
        prefix, _, argument = name.partition(":")
        takes: Any = self._entries.get(prefix)
        field = getattr(takes, "argument", None)
        if not field:
            return None
        if name not in self._bound:
            if not argument:
                raise UnknownName(f"{self.kind} {name!r}: give its {field} after the colon")
            self._bound[name] = takes.with_argument(argument)
        return self._bound[name]

    def _import(self, path: str) -> T:
        module_name, _, attr = path.partition(":")
        try:
            module = plugin_guard.importing(module_name)
        except plugin_guard.PluginError as err:  # it names the module and what it did
            raise UnknownName(f"{self.kind} {path!r}: {err}") from None
        except Exception as err:
            raise UnknownName(
                f"{self.kind} {path!r}: cannot import module {module_name!r} "
                f"({type(err).__name__}: {err})"
            ) from None
        cls = getattr(module, attr, None)
        if cls is None:
            raise UnknownName(f"{self.kind} {path!r}: module {module_name!r} has no {attr!r}")
        self._check(cls, path)
        return cls  # type: ignore[no-any-return]

    def _check(self, cls: object, name: str) -> None:
        if not (isinstance(cls, type) and issubclass(cls, self.base)):
            raise UnknownName(
                f"{self.kind} {name!r}: {cls!r} is not a subclass of {self.base.__name__}"
            )


def _is_ours(cls: type) -> bool:
    return cls.__module__.split(".")[0] == __name__.split(".")[0]
