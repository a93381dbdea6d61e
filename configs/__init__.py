"""Built-in YAML configurations and the validating loader behind every one of them.

The YAML files beside this module (``arms/``, ``robots/``, ``walls/``, ...) are the
project's configuration. Code never reads them with a bare ``yaml.safe_load``: it declares
a *schema* (a mapping of key -> :class:`Spec`) and calls :func:`load`, which

* finds the file (a built-in name such as ``"pincher"`` or a path to any YAML file),
* rejects unknown keys, wrong types, wrong lengths, NaN and out-of-range values with a
  :class:`ConfigError` whose message names the file, the key, the bad value and what
  would be valid,
* fills in defaults and returns plain Python values (``float``, ``int``, ``str``,
  lists of them, nested dicts).

This module sits at the bottom of the dependency graph (it imports only PyYAML), so
``kinematics``, ``envs`` and ``kinegym`` can all use it. Units are part of the key names
(``*_cm``, ``*_deg``); the consumers convert degrees to radians.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .errors import ConfigError
from .io import FileError, load_yaml, parse_yaml, read_bytes, read_text, write_atomic

__all__ = [
    "CONFIG_DIR",
    "ConfigError",
    "FileError",
    "load_yaml",
    "parse_yaml",
    "read_bytes",
    "read_text",
    "write_atomic",
    "Spec",
    "Number",
    "Text",
    "Flag",
    "Vector",
    "Matrix",
    "Section",
    "Opaque",
    "ListOf",
    "available",
    "resolve",
    "load",
    "validate",
]

CONFIG_DIR: Path = Path(__file__).resolve().parent
_REQUIRED = object()


@dataclass(frozen=True)
class Spec:
    """Base of all schema entries; ``doc`` says what the key means (with its unit)."""

    default: Any = _REQUIRED
    doc: str = ""

    @property
    def required(self) -> bool:
        return self.default is _REQUIRED

    def check(self, value: Any, source: str, key: str) -> Any:  # pragma: no cover - abstract
        raise NotImplementedError


def _is_number(value: Any) -> bool:
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@dataclass(frozen=True)
class Number(Spec):
    """A finite real (or integer) with optional bounds."""

    lo: float | None = None
    hi: float | None = None
    lo_open: bool = False
    integer: bool = False

    def describe(self) -> str:
        kind = "an integer" if self.integer else "a finite number"
        parts = []
        if self.lo is not None:
            parts.append(f"{'>' if self.lo_open else '>='} {self.lo:g}")
        if self.hi is not None:
            parts.append(f"<= {self.hi:g}")
        return kind + (" " + " and ".join(parts) if parts else "")

    def check(self, value: Any, source: str, key: str) -> Any:
        try:
            ok = _is_number(value) and math.isfinite(value)
        except OverflowError:  # an integer too large for a float
            ok = False
        if ok and self.integer and not float(value).is_integer():
            ok = False
        if ok and self.lo is not None:
            ok = value > self.lo if self.lo_open else value >= self.lo
        if ok and self.hi is not None:
            ok = value <= self.hi
        if not ok:
            raise ConfigError(source, key, value, self.describe())
        return int(value) if self.integer else float(value)


@dataclass(frozen=True)
class Text(Spec):
    """A string, optionally one of a fixed set of choices."""

    choices: tuple[str, ...] | None = None

    def check(self, value: Any, source: str, key: str) -> Any:
        if not isinstance(value, str):
            raise ConfigError(source, key, value, "a string")
        if self.choices is not None and value not in self.choices:
            raise ConfigError(source, key, value, "one of " + ", ".join(self.choices))
        return value


@dataclass(frozen=True)
class Flag(Spec):
    """A boolean (``true`` / ``false``)."""

    def check(self, value: Any, source: str, key: str) -> Any:
        if not isinstance(value, bool):
            raise ConfigError(source, key, value, "true or false")
        return value


@dataclass(frozen=True)
class Vector(Spec):
    """A list of numbers of a fixed length; each element checked by ``item``."""

    length: int | None = None
    item: Number = field(default_factory=Number)

    def check(self, value: Any, source: str, key: str) -> Any:
        n = "" if self.length is None else f"{self.length} "
        if not isinstance(value, (list, tuple)) or (
            self.length is not None and len(value) != self.length
        ):
            raise ConfigError(source, key, value, f"a list of {n}numbers")
        return [self.item.check(v, source, f"{key}[{i}]") for i, v in enumerate(value)]


@dataclass(frozen=True)
class Matrix(Spec):
    """A list of ``rows`` lists of ``cols`` numbers (``rows=None``: any number of rows)."""

    rows: int | None = None
    cols: int = 2
    item: Number = field(default_factory=Number)

    def check(self, value: Any, source: str, key: str) -> Any:
        shape = f"{'N' if self.rows is None else self.rows} x {self.cols}"
        if not isinstance(value, (list, tuple)) or (
            self.rows is not None and len(value) != self.rows
        ):
            raise ConfigError(source, key, value, f"a {shape} list of lists of numbers")
        row_spec = Vector(length=self.cols, item=self.item)
        return [row_spec.check(r, source, f"{key}[{i}]") for i, r in enumerate(value)]


@dataclass(frozen=True)
class Section(Spec):
    """A nested mapping validated against its own schema."""

    fields: Mapping[str, Spec] = field(default_factory=dict)

    def check(self, value: Any, source: str, key: str) -> Any:
        return validate(value, self.fields, source, prefix=key)


@dataclass(frozen=True)
class Opaque(Spec):
    """A nested mapping whose keys its consumer validates with a schema of its own.

    One robot file describes the whole robot, but each part reads its own section: the
    kinematics reads the geometry and passes the simulation's section (``physics:``,
    ``sim:``) through; the simulation validates it on load, next to its defaults."""

    def check(self, value: Any, source: str, key: str) -> Any:
        if not isinstance(value, Mapping):
            raise ConfigError(source, key, value, "a mapping of keys to values")
        return dict(value)


@dataclass(frozen=True)
class ListOf(Spec):
    """A list whose items all follow ``item``; length within ``[min_len, max_len]``."""

    item: Spec = field(default_factory=Spec)
    min_len: int = 0
    max_len: int | None = None

    def check(self, value: Any, source: str, key: str) -> Any:
        bad_len = not isinstance(value, (list, tuple)) or len(value) < self.min_len or (
            self.max_len is not None and len(value) > self.max_len
        )
        if bad_len:
            hi = "any number" if self.max_len is None else str(self.max_len)
            n = str(self.min_len) if self.min_len == self.max_len else f"{self.min_len}..{hi}"
            raise ConfigError(source, key, value, f"a list of {n} items")
        return [self.item.check(v, source, f"{key}[{i}]") for i, v in enumerate(value)]


def validate(
    data: Any, schema: Mapping[str, Spec], source: str = "<config>", prefix: str = ""
) -> dict[str, Any]:
    """Check ``data`` against ``schema``; return a new dict with defaults filled in.

    Raises:
        ConfigError: unknown key, missing required key or a bad value, naming ``source``
            and the dotted key.
    """
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise ConfigError(source, prefix, data, "a mapping of keys to values")
    unknown = sorted(set(map(str, data)) - set(schema))
    if unknown:
        key = f"{prefix}.{unknown[0]}" if prefix else unknown[0]
        raise ConfigError(
            source, key, data[unknown[0]], "no such key; known keys: " + ", ".join(schema)
        )
    out: dict[str, Any] = {}
    for name, spec in schema.items():
        key = f"{prefix}.{name}" if prefix else name
        if name in data:
            out[name] = spec.check(data[name], source, key)
        elif spec.required:
            raise ConfigError(source, key, None, f"a value ({spec.doc or 'required'})")
        else:
            default = spec.default
            out[name] = spec.check(default, source, key) if default is not None else None
    return out


def available(kind: str) -> list[str]:
    """Names of the built-in configurations of one kind (``"arms"``, ``"walls"``, ...)."""
    return sorted(p.stem for p in (CONFIG_DIR / kind).glob("*.yaml"))


def resolve(kind: str, name_or_path: str | Path) -> Path:
    """Find a configuration: an existing file path, or a built-in name of ``kind``.

    Raises:
        ConfigError: neither a file nor a built-in name (lists the built-in names).
    """
    path = Path(name_or_path)
    try:
        if path.suffix in (".yaml", ".yml") or path.exists():
            if path.is_file():
                return path
            raise ConfigError(str(path), "", str(name_or_path), "an existing YAML file")
        builtin = CONFIG_DIR / kind / f"{name_or_path}.yaml"
        if builtin.is_file():
            return builtin
    except OSError as err:  # a name too long for the file system, ...
        raise ConfigError(str(path)[:80], "", str(name_or_path)[:80],
                          f"a usable file name ({err.strerror})") from None
    names = ", ".join(available(kind)) or "none"
    raise ConfigError(
        f"configs/{kind}", "", str(name_or_path), f"a YAML file path or one of: {names}"
    )


def load(kind: str, name_or_path: str | Path, schema: Mapping[str, Spec]) -> dict[str, Any]:
    """Read, parse and validate one configuration file (see :func:`resolve`)."""
    path = resolve(kind, name_or_path)
    data = load_yaml(path)
    if data is None:
        raise ConfigError(str(path), "", "an empty file", "a mapping of keys to values")
    return validate(data, schema, source=str(path))
