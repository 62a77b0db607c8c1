"""JSON form of the typed results, for :mod:`ladders.study.running.store` only.

:func:`encode` turns a :class:`~ladders.study.running.results.PairResult` or
:class:`~ladders.study.running.results.FailedPair` into a JSON-ready dict with
``schema_version`` and ``status``; :func:`decode` reads it back and refuses
anything it cannot read whole (:class:`ResultSchemaError`, naming the field): a
file of another schema version, a missing or extra field, a value of the wrong
type or a non-finite number.

Per-vertex arrays (tuples of more than :data:`LIST_LIMIT` floats: strain maps,
displacements, momenta) are stored exactly and compactly as
``{"float64_base64": <little-endian IEEE 754 bytes in base64>}``; shorter tuples as
JSON lists.
"""

from __future__ import annotations

import base64
import dataclasses
import math
import typing

import numpy as np

from .results import SCHEMA_VERSION, FailedPair, PairResult

__all__ = ["ResultSchemaError", "encode", "decode", "schema_version", "LIST_LIMIT"]

#: Float tuples longer than this are stored as base64 float64 rather than JSON lists.
LIST_LIMIT = 16
_ARRAY_KEY = "float64_base64"


class ResultSchemaError(ValueError):
    """A stored result that cannot be read whole; the message says what is wrong."""


def encode(result: PairResult | FailedPair) -> dict:
    """The JSON-ready dict of ``result``, with ``schema_version`` and ``status`` first.

    An optional field (``optional_fields`` of the class) at its default is left out,
    so a result that does not use it is stored as before the field existed.
    """
    body = _compact(dataclasses.asdict(result))
    for f in dataclasses.fields(result):
        if (
            f.name in getattr(result, "optional_fields", ())
            and getattr(result, f.name) == f.default
        ):
            body.pop(f.name)
    return {"schema_version": SCHEMA_VERSION, "status": result.status, **body}


def _compact(node):
    """``node`` with every long tuple of floats as a base64 float64 record."""
    if isinstance(node, dict):
        return {k: _compact(v) for k, v in node.items()}
    if isinstance(node, (tuple, list)):
        if len(node) > LIST_LIMIT and all(type(v) is float for v in node):
            raw = np.asarray(node, dtype="<f8").tobytes()
            return {_ARRAY_KEY: base64.b64encode(raw).decode("ascii")}
        return [_compact(v) for v in node]
    return node


def _expand(value, path: str) -> list:
    """The list of floats of a base64 float64 record."""
    if set(value) != {_ARRAY_KEY} or not isinstance(value[_ARRAY_KEY], str):
        raise ResultSchemaError(f"{path}: expected a list or {{{_ARRAY_KEY!r}: ...}}")
    try:
        raw = base64.b64decode(value[_ARRAY_KEY], validate=True)
        return np.frombuffer(raw, dtype="<f8").tolist()
    except ValueError as exc:
        raise ResultSchemaError(f"{path}: unreadable float64 array ({exc})") from None


def schema_version(data) -> int | None:
    """The schema version of stored data (1 for files written before versions existed)."""
    if not isinstance(data, dict):
        return None
    version = data.get("schema_version", 1)
    return version if isinstance(version, int) and not isinstance(version, bool) else None


def decode(data) -> PairResult | FailedPair:
    """The typed result stored as ``data`` (a parsed JSON object).

    Raises
    ------
    ResultSchemaError
        ``data`` is of another schema version or does not hold the whole result.
    """
    version = schema_version(data)
    if version != SCHEMA_VERSION:
        raise ResultSchemaError(
            f"written with result schema {version}, this version reads schema {SCHEMA_VERSION}"
        )
    status = data.get("status")
    classes = {"ok": PairResult, "failed": FailedPair}
    if status not in classes:
        raise ResultSchemaError(f"status: expected 'ok' or 'failed', got {status!r}")
    body = {k: v for k, v in data.items() if k not in ("schema_version", "status", "params_hash")}
    return _build(classes[status], body, "")


def _build(cls, node, path: str):
    """An instance of the dataclass ``cls`` from the dict ``node`` (every field, no other;
    a field of ``cls.optional_fields`` may be absent and is then its default)."""
    if not isinstance(node, dict):
        raise ResultSchemaError(f"{path or 'result'}: expected an object, got {node!r:.40}")
    hints = typing.get_type_hints(cls)
    optional = getattr(cls, "optional_fields", ())
    names = [f.name for f in dataclasses.fields(cls) if f.name in node or f.name not in optional]
    missing = [n for n in names if n not in node]
    extra = sorted(set(node) - set(names))
    if missing or extra:
        what = f"missing {missing}" if missing else f"unexpected {extra}"
        raise ResultSchemaError(f"{path or 'result'}: {what}")
    return cls(**{n: _value(hints[n], node[n], f"{path}.{n}" if path else n) for n in names})


def _value(hint, value, path: str):
    """``value`` checked against the type ``hint`` of a field."""
    if dataclasses.is_dataclass(hint):
        return _build(hint, value, path)
    origin = typing.get_origin(hint)
    if origin is tuple:
        item = typing.get_args(hint)[0]
        if item is float and isinstance(value, dict):
            value = _expand(value, path)
        if not isinstance(value, list):
            raise ResultSchemaError(f"{path}: expected a list, got {type(value).__name__}")
        return tuple(_value(item, v, f"{path}[{i}]") for i, v in enumerate(value))
    checks = {
        float: lambda v: (
            isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
        ),
        int: lambda v: isinstance(v, int) and not isinstance(v, bool),
        bool: lambda v: isinstance(v, bool),
        str: lambda v: isinstance(v, str),
    }
    if hint not in checks or not checks[hint](value):
        name = getattr(hint, "__name__", str(hint))
        raise ResultSchemaError(f"{path}: expected a finite {name}, got {value!r:.40}")
    return float(value) if hint is float else value
