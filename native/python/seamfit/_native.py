"""Access to the compiled core, with a clear message when it is missing."""
from __future__ import annotations

from .errors import SeamfitError

_core = None


def core():
    """Return the ``seamfit._core`` extension module (imported on first use)."""
    global _core
    if _core is None:
        try:
            from . import _core as mod  # type: ignore[attr-defined]
        except ImportError as exc:  # pragma: no cover - depends on the build
            raise SeamfitError(
                "the compiled core seamfit._core is not built; install seamfit with "
                "'pip install .' (see README)") from exc
        _core = mod
    return _core
