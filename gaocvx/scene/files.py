"""Reading scenes: TOML files, ``--set key=value`` overrides, size limits."""

from __future__ import annotations

import re
import tomllib
from pathlib import Path
from typing import Any, Mapping

from ..errors import SceneError
from .core import Scene, _assign

# A scene needs arrays two levels deep ([[x, q], ...]); this is far beyond any.
MAX_NESTING = 64
# Scene and result files are read whole; 10^6 point forces take ~40 MB of TOML.
MAX_FILE_BYTES = 256 << 20


def _nesting(text: str) -> tuple[int, int, str | None]:
    """The deepest bracket nesting of TOML text, its line, and the dotted key there.

    Brackets inside strings and comments are skipped roughly (a quote opens a
    string until the same quote, ``#`` outside one ends the line); table
    headers and ``key =`` count only outside any bracket.  Good enough to name
    the key of an absurdly deep array, which is all this is for.
    """
    depth = deepest = 0
    where, key_there = 1, None
    table, key = "", None
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if depth == 0 and stripped and not stripped.startswith("#"):
            header = re.fullmatch(r"\[\[?\s*([A-Za-z0-9_.\-\"' ]+?)\s*\]\]?\s*(#.*)?", stripped)
            if header:
                table, key = header.group(1).replace('"', "").replace("'", ""), None
            elif "=" in stripped:
                key = stripped.split("=", 1)[0].strip().strip("\"'")
        quote = None
        for ch in line:
            if quote:
                if ch == quote:
                    quote = None
            elif ch in "\"'":
                quote = ch
            elif ch == "#":
                break
            elif ch in "[{":
                depth += 1
                if depth > deepest:
                    deepest, where = depth, number
                    key_there = f"{table}.{key}" if table and key else (key or table or None)
            elif ch in "]}":
                depth = max(depth - 1, 0)
    return deepest, where, key_there


def _parse_toml(text: str, where: str, *, value_key: str | None = None) -> dict:
    """Parse TOML text, turning every failure into one SceneError.

    ``where`` names the source (a file) for syntax errors; ``value_key`` is
    the dotted key when the text is one ``--set`` value.
    """
    depth, line, key = _nesting(text)
    if depth > MAX_NESTING:
        key = value_key or key or where
        raise SceneError(key, f"arrays or tables nested more than {MAX_NESTING} "
                         f"levels deep", f"{depth} levels at line {line}")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError:
        raise
    except RecursionError:  # pragma: no cover - the depth check above comes first
        raise SceneError(value_key or where, "nested too deeply to read") from None
    except ValueError as exc:  # e.g. an integer of more than 4300 digits
        raise SceneError(value_key or where, f"cannot read a value: {exc}") from None


def parse_set(text: str) -> tuple[str, Any]:
    """Parse a ``--set KEY=VALUE`` argument; VALUE uses TOML value syntax.

    A bare word that is not a TOML value (``beam.model=gao``) is taken as a
    string.

    Examples
    --------
    >>> parse_set("foundation.stiffness=5e12")
    ('foundation.stiffness', 5000000000000.0)
    >>> parse_set("beam.supports=P3")
    ('beam.supports', 'P3')
    """
    if "=" not in text:
        raise SceneError("--set", "must be KEY=VALUE", text)
    key, raw = (s.strip() for s in text.split("=", 1))
    if not key:
        raise SceneError("--set", "must be KEY=VALUE", text)
    try:
        value = _parse_toml(f"v = {raw}", "--set", value_key=key)["v"]
    except tomllib.TOMLDecodeError:
        if raw and all(c.isalnum() or c in "-_." for c in raw):
            value = raw
        else:
            raise SceneError(key, "is not a TOML value", raw) from None
    return key, value


def read_text(path, what: str = "scene file") -> str:
    """The text of a UTF-8 file of at most MAX_FILE_BYTES; a byte-order mark is skipped.

    Raises
    ------
    SceneError
        Keyed by the path, when the file cannot be read or is not UTF-8 text
        (a UTF-16 file is named as such).
    """
    path = Path(path)
    key = str(path)
    try:
        with open(path, "rb") as fh:
            data = fh.read(MAX_FILE_BYTES + 1)
    except OSError as exc:
        raise SceneError(key, f"cannot read the {what}: {exc.strerror or exc}", key) from None
    except MemoryError:
        raise SceneError(key, f"the {what} is too large to read") from None
    if len(data) > MAX_FILE_BYTES:
        raise SceneError(key, f"the {what} is larger than {MAX_FILE_BYTES >> 20} MB",
                         f"more than {MAX_FILE_BYTES} bytes")
    if data.startswith((b"\xff\xfe", b"\xfe\xff")):
        raise SceneError(key, f"the {what} is UTF-16 text; save it as UTF-8", "UTF-16")
    nul = data.find(b"\x00")
    if nul >= 0:
        raise SceneError(key, f"the {what} contains NUL bytes (UTF-16 without a byte-order "
                         "mark, or binary data); save it as UTF-8 text", f"byte {nul}")
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        line = data.count(b"\n", 0, exc.start) + 1
        raise SceneError(key, f"the {what} is not UTF-8 text: byte 0x{data[exc.start]:02x} "
                         f"at line {line} cannot be decoded; save it as UTF-8",
                         f"byte {exc.start}") from None


def load_scene(path, overrides: Mapping[str, Any] | None = None) -> Scene:
    """Read and validate a TOML scene file, applying dotted-key overrides.

    The file must be UTF-8 (a byte-order mark is allowed).

    Raises
    ------
    SceneError
        If the file cannot be read or parsed, or any value is invalid.
    """
    text = read_text(path)
    try:
        data = _parse_toml(text, str(path))
    except tomllib.TOMLDecodeError as exc:
        raise SceneError(str(path), f"not valid TOML: {exc}") from None
    for key, value in (overrides or {}).items():
        _assign(data, key, value)
    return Scene.from_dict(data)

