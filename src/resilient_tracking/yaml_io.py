"""Reading a scenario's YAML text within bounds a hostile file cannot break.

:func:`read_yaml` reads at most :data:`MAX_FILE_BYTES` of a file and parses it with PyYAML's
safe loader, plus four rules (docs/reliability.md §7):

- **size**: a larger file is refused before it is parsed (a maximal scenario, 64 robots and 64
  targets with long waypoint lists, is far below the limit);
- **aliases**: anchors and aliases (``&a`` / ``*a``) may add at most :data:`MAX_ALIAS_NODES`
  nodes to the document once expanded, and may not refer to themselves; an "alias bomb" (a few
  lines expanding to billions of nodes) is refused after composing, before anything walks it;
- **duplicate keys**: a key given twice in one mapping is an error naming both lines (YAML
  forbids it; PyYAML would silently keep the last value);
- **numbers**: floats are read as YAML 1.2 writes them, so ``1.0e12`` and ``1e-3`` are numbers
  (PyYAML's YAML 1.1 rules need a signed exponent and read them as strings).

Every message is bounded in length, however large the offending input.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import yaml
from yaml.nodes import MappingNode, Node, SequenceNode

#: Largest scenario file read, in bytes.
MAX_FILE_BYTES = 256 * 1024
#: Nodes that aliases may add to a document once expanded.
MAX_ALIAS_NODES = 10_000
#: Longest text of an error message taken from the parser.
MAX_MESSAGE_CHARS = 400

_MERGE_TAG = "tag:yaml.org,2002:merge"

# YAML 1.2 core schema floats (with PyYAML's ``.inf``/``.nan`` spellings kept).
_FLOAT_12 = re.compile(
    r"""^(?:[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?
        |[-+]?\.(?:inf|Inf|INF)
        |\.(?:nan|NaN|NAN))$""",
    re.X,
)
_INT_ONLY = re.compile(r"^[-+]?[0-9]+$")


class YamlInputError(ValueError):
    """The file is refused; ``where`` is ``<file>`` or ``<yaml>``, ``reason`` says why."""

    def __init__(self, where: str, reason: str):
        self.where = where
        self.reason = reason
        super().__init__(f"{where}: {reason}")


def bounded(text: str, limit: int = MAX_MESSAGE_CHARS) -> str:
    """``text`` cut to ``limit`` characters."""
    return text if len(text) <= limit else text[: limit - 3] + "..."


class BoundedLoader(yaml.SafeLoader):
    """PyYAML's safe loader with the alias budget, duplicate-key check and YAML 1.2 floats."""

    def get_single_node(self) -> Node | None:
        """Compose the document, then refuse it if its aliases expand it by more than
        :data:`MAX_ALIAS_NODES` nodes or refer to themselves."""
        node = super().get_single_node()
        if node is not None:
            _check_expansion(node)
        return node

    def construct_mapping(self, node: MappingNode, deep: bool = False) -> dict[Any, Any]:
        """PyYAML's mapping, after refusing a key given twice (the error names both lines)."""
        if isinstance(node, MappingNode):
            _check_duplicates(self, node)
        return super().construct_mapping(node, deep=deep)


def _float_or_int(loader: BoundedLoader, node: yaml.ScalarNode) -> Any:
    """A plain scalar matching the YAML 1.2 float pattern: an int if it is one, else a float."""
    value = loader.construct_scalar(node)
    if _INT_ONLY.match(str(value)):
        return loader.construct_yaml_int(node)
    return loader.construct_yaml_float(node)


# Appended after PyYAML's own resolvers, so it only decides what they leave as a string
# (``1.0e12``, ``1e5``); integers stay integers.
BoundedLoader.add_implicit_resolver("tag:yaml.org,2002:float", _FLOAT_12, list("-+0123456789."))
BoundedLoader.add_constructor("tag:yaml.org,2002:float", _float_or_int)


def _check_duplicates(loader: BoundedLoader, node: MappingNode) -> None:
    seen: dict[Any, int] = {}
    for key_node, _ in node.value:
        if key_node.tag == _MERGE_TAG or not isinstance(key_node, yaml.ScalarNode):
            continue
        key = loader.construct_object(key_node)
        line = key_node.start_mark.line + 1
        try:
            first = seen.get(key)
            seen.setdefault(key, line)
        except TypeError:  # an unhashable key: PyYAML refuses it itself
            continue
        if first is not None:
            raise YamlInputError(
                "<yaml>",
                f"duplicate key {bounded(repr(key), 60)} at line {line} "
                f"(first given at line {first}); give each key once",
            )


def _check_expansion(root: Node) -> None:
    """Refuse a document whose aliases expand it by more than the budget, or refer to
    themselves. Counts nodes as written (each node once) and as expanded (each time reached),
    without expanding anything."""
    expanded: dict[int, int] = {}
    visiting: set[int] = set()
    budget_total = [0]  # nodes as written

    def size(node: Node) -> int:
        key = id(node)
        if key in expanded:
            return expanded[key]
        if key in visiting:
            raise YamlInputError("<yaml>", "an alias refers to a node that contains it")
        visiting.add(key)
        budget_total[0] += 1
        total = 1
        if isinstance(node, SequenceNode):
            total += sum(size(child) for child in node.value)
        elif isinstance(node, MappingNode):
            total += sum(size(k) + size(v) for k, v in node.value)
        visiting.discard(key)
        expanded[key] = total
        return total

    try:
        total = size(root)
    except RecursionError:
        raise YamlInputError("<yaml>", "nested too deeply to be a scenario") from None
    if total - budget_total[0] > MAX_ALIAS_NODES:
        raise YamlInputError(
            "<yaml>",
            f"aliases expand the document by more than {MAX_ALIAS_NODES} nodes "
            f"({budget_total[0]} nodes written, {total:.3g} expanded); write the values out",
        )


def read_text(path: Path, limit: int = MAX_FILE_BYTES) -> str:
    """The UTF-8 text of ``path``, refused if longer than ``limit`` bytes."""
    try:
        with path.open("rb") as handle:
            data = handle.read(limit + 1)
    except OSError as err:
        raise YamlInputError("<file>", f"cannot read ({err.strerror})") from None
    if len(data) > limit:
        raise YamlInputError("<file>", f"larger than {limit} bytes, the limit for a scenario file")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise YamlInputError("<file>", f"not UTF-8 text ({err.reason})") from None


def parse_yaml(text: str) -> Any:
    """The document in ``text`` under :class:`BoundedLoader`'s rules."""
    try:
        return yaml.load(text, Loader=BoundedLoader)  # noqa: S506 - a SafeLoader subclass
    except yaml.YAMLError as err:
        raise YamlInputError("<yaml>", f"not valid YAML ({bounded(str(err))})") from None
    except RecursionError:
        raise YamlInputError("<yaml>", "nested too deeply to be a scenario") from None


def read_yaml(path: str | Path) -> Any:
    """Read and parse a YAML file within the bounds above; :class:`YamlInputError` if not."""
    return parse_yaml(read_text(Path(path)))
