"""A pattern file's JSON document, with the errors a user can cause as PatternError naming the file."""
from __future__ import annotations

import json
from pathlib import Path

from ..errors import PatternError


def read_json(path: Path, what: str):
    """The parsed JSON of the ``what`` file at ``path`` (e.g. 'pattern', 'GarmentCode')."""
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise PatternError(f"{path}: cannot read {what} file ({exc.strerror})") from exc
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise PatternError(f"{path}: invalid JSON at line {exc.lineno}, column {exc.colno}: {exc.msg}") from exc
