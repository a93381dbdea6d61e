"""The one input boundary and the one output boundary of kinegym.

Everything the program reads from a user's disk comes through :func:`read_bytes` (a size
bound, a regular file, readable) and, for text, :func:`read_text` (UTF-8 checked) or
:func:`load_yaml` (also a bound on the document's *expanded* size: a "billion laughs" file of
nested anchors and aliases is refused before anything walks it). Everything it writes goes
through :func:`write_atomic`: the parent folder is made (or a named error says why it
cannot be), the extension is checked, the bytes go to a temporary file beside the target
and are renamed over it - a reader never sees half a file, and a process killed mid-write
leaves the old file (or none), never a corrupt one.

Errors are :class:`FileError` (a :class:`~kinegym.configs.ConfigError`, so a ``ValueError``):
the path, what was wrong, what would be valid. The CLI maps them to exit code 2.
This module imports only the standard library and PyYAML.
"""

from __future__ import annotations

import os
import tempfile
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import yaml

from .errors import ConfigError

__all__ = ["FileError", "read_bytes", "read_text", "load_yaml", "parse_yaml", "write_atomic",
           "MAX_YAML_BYTES", "MAX_YAML_NODES"]

#: Largest YAML file read (configurations are a few kB).
MAX_YAML_BYTES = 1 << 20
#: Most nodes a YAML document may expand to, aliases counted as often as they are used.
MAX_YAML_NODES = 200_000


class FileError(ConfigError):
    """A file cannot be read or written as asked: ``source`` (the path), ``value`` (what was
    wrong), ``expected`` (what would be valid)."""

    def __init__(self, path: str | Path, problem: str, expected: str) -> None:
        self.source, self.key, self.value, self.expected = str(path), "", problem, expected
        ValueError.__init__(self, f"{path}: {problem}; expected {expected}")


def read_bytes(path: str | Path, max_bytes: int, what: str = "file") -> bytes:
    """The bytes of a regular file of at most ``max_bytes``; :class:`FileError` otherwise."""
    p = Path(path)
    try:
        st = p.stat()
    except FileNotFoundError:
        raise FileError(p, "no such file", f"an existing {what}") from None
    except OSError as err:
        raise FileError(p, f"cannot be read ({err.strerror or err})", f"a readable {what}") from None
    import stat as _stat

    if not _stat.S_ISREG(st.st_mode):
        kind = "a folder" if _stat.S_ISDIR(st.st_mode) else "not a regular file"
        raise FileError(p, kind, f"a {what}")
    if st.st_size > max_bytes:
        raise FileError(p, f"{st.st_size:,} bytes", f"a {what} of at most {max_bytes:,} bytes")
    chunks, total = [], 0
    try:
        with p.open("rb") as fh:
            while chunk := fh.read(min(1 << 20, max_bytes + 1)):
                chunks.append(chunk)
                total += len(chunk)
                if total > max_bytes:  # grew while we looked, or a special file that lied about its size
                    raise FileError(p, f"more than {max_bytes:,} bytes", f"a {what} of at most {max_bytes:,} bytes")
    except OSError as err:
        raise FileError(p, f"cannot be read ({err.strerror or err})", f"a readable {what}") from None
    return b"".join(chunks)


def read_text(path: str | Path, max_bytes: int = MAX_YAML_BYTES, what: str = "text file") -> str:
    """A UTF-8 text file of at most ``max_bytes`` (a binary file is a :class:`FileError`)."""
    data = read_bytes(path, max_bytes, what)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        raise FileError(path, f"not UTF-8 text (byte {err.start})", f"a UTF-8 {what}") from None
    if "\x00" in text:
        raise FileError(path, "binary data (a NUL byte)", f"a UTF-8 {what}")
    return text


def _expanded_size(node: yaml.Node, memo: dict[int, int], budget: int, depth: int = 0) -> int:
    """Nodes ``node`` stands for once every alias is expanded (memoised per node: linear time)."""
    key = id(node)
    if key in memo:
        return memo[key]
    if depth > 200:
        raise ValueError("nested deeper than 200 levels")
    memo[key] = budget + 1  # a node reached again while it is being sized is a cycle: over budget
    total = 1
    if isinstance(node, yaml.SequenceNode):
        for child in node.value:
            total += _expanded_size(child, memo, budget, depth + 1)
            if total > budget:
                break
    elif isinstance(node, yaml.MappingNode):
        for k, v in node.value:
            total += _expanded_size(k, memo, budget, depth + 1) + _expanded_size(v, memo, budget, depth + 1)
            if total > budget:
                break
    memo[key] = total
    return total


def parse_yaml(text: str, source: str = "<yaml>", max_nodes: int = MAX_YAML_NODES) -> Any:
    """Parse one YAML document safely (PyYAML's SafeLoader) after checking that it expands to
    at most ``max_nodes`` nodes; :class:`FileError` for unparsable or oversized documents."""
    loader = yaml.SafeLoader(text)
    try:
        node = loader.get_single_node()
        if node is None:
            return None
        try:
            size = _expanded_size(node, {}, max_nodes)
        except ValueError as err:
            raise FileError(source, f"a YAML document {err}", "a plain configuration") from None
        if size > max_nodes:
            raise FileError(source, f"a YAML document expanding to more than {max_nodes:,} nodes (aliases)",
                            f"at most {max_nodes:,} nodes once anchors are expanded")
        return loader.construct_document(node)
    except yaml.YAMLError as exc:
        msg = " ".join(str(exc).split())
        raise FileError(source, f"unparsable YAML ({msg[:200]})", "valid YAML") from None
    except RecursionError:
        raise FileError(source, "a YAML document nested too deeply", "a plain configuration") from None
    finally:
        loader.dispose()


def load_yaml(path: str | Path, max_bytes: int = MAX_YAML_BYTES, max_nodes: int = MAX_YAML_NODES) -> Any:
    """Read (:func:`read_text`) and parse (:func:`parse_yaml`) one bounded YAML file."""
    return parse_yaml(read_text(path, max_bytes, "YAML file"), str(path), max_nodes)


def write_atomic(path: str | Path, data: bytes | str, suffixes: Sequence[str] | None = None,
                 what: str = "file") -> Path:
    """Write ``data`` to ``path`` all at once and return the path.

    The extension must be one of ``suffixes`` (case-insensitive) when given; the parent folder
    is created; the data goes to a temporary file in the same folder, is flushed to disk and
    renamed over ``path``. Any failure is a :class:`FileError` naming the path and the reason,
    and leaves no temporary file behind."""
    out = Path(path)
    if suffixes is not None and out.suffix.lower() not in {s.lower() for s in suffixes}:
        raise FileError(out, f"extension {out.suffix or '(none)'!r}",
                        f"a {what} path ending in {' or '.join(suffixes)}")
    if out.name in ("", ".", ".."):
        raise FileError(out, "no file name", f"a {what} path")
    if out.is_dir():
        raise FileError(out, "a folder", f"a {what} path (a folder's name is taken)")
    for parent in [out.parent, *out.parent.parents]:
        if parent.exists():
            if not parent.is_dir():
                raise FileError(out, f"{str(parent)!r} is a file, not a folder", f"a {what} path in a folder")
            break
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        raise FileError(out, f"its folder cannot be made ({err.strerror or err})", f"a writable {what} path") from None
    payload = data.encode("utf-8") if isinstance(data, str) else bytes(data)
    tmp = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{out.name}.", suffix=".tmp", dir=out.parent)
        with os.fdopen(fd, "wb") as fh:
            umask = os.umask(0)  # mkstemp makes the file private (0600); give it the mode open() would
            os.umask(umask)
            os.fchmod(fh.fileno(), 0o666 & ~umask)
            fh.write(payload)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, out)
        tmp = None
    except OSError as err:
        raise FileError(out, f"cannot be written ({err.strerror or err})", f"a writable {what} path") from None
    finally:
        if tmp is not None:
            try:
                os.unlink(tmp)
            except OSError:
                pass
    return out
