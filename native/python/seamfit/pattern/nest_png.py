"""The grading nest as a PNG picture: the same sheet layout as the true-scale SVG
(``seamfit.pattern.svg``: each panel in its slot, every pattern's copy aligned at the
panel's top-centre, the base in black), drawn with matplotlib for reports and READMEs.
"""
from __future__ import annotations

import io
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from ..errors import PatternError
from ..fileio import atomic_write_bytes
from .model import Pattern
from .svg import MARGIN_CM, _layout, nest_slots


def render_nest_png(path: str | Path, patterns: Pattern | Sequence[Pattern], *,
                    labels: Sequence[str] | None = None, title: str | None = None,
                    px_per_cm: float = 6.0) -> Path:
    """Draw one pattern or a nest (the first is the base) to a PNG, written atomically."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    pats = [patterns] if isinstance(patterns, Pattern) else list(patterns)
    if not pats:
        raise PatternError(f"{path}: no pattern to draw")
    names, colors, order = nest_slots(pats, labels)
    width, height = _layout(order, MARGIN_CM)
    # Same proportions as the sheet, capped so a large nest stays a reasonable picture.
    scale = min(px_per_cm, 2400.0 / max(width, height))
    fig = plt.figure(figsize=(width * scale / 100, height * scale / 100 + 0.6), dpi=100)
    ax = fig.add_axes((0, 0, 1, height / (height + 60 / scale)))
    for k in reversed(range(len(pats))):      # base last, on top
        for slot in order:
            for kk, panel in slot.members:
                if kk != k:
                    continue
                pts = slot.sheet(panel)
                pts = np.vstack([pts, pts[:1]])
                ax.plot(pts[:, 0], pts[:, 1], color=colors[k], lw=1.6 if k == 0 else 1.2,
                        label=names[k] if slot is next(s for s in order if any(m == k for m, _ in s.members)) else None)
                if k == slot.members[0][0]:
                    c = pts[:-1].mean(axis=0)
                    ax.text(c[0], c[1], slot.name, ha="center", va="center", fontsize=8, color="#444444")
    ax.set_xlim(0, width)
    ax.set_ylim(height, 0)                      # sheet y points down, as in the SVG
    ax.set_aspect("equal")
    ax.axis("off")
    handles, labs = ax.get_legend_handles_labels()
    order_k = sorted(range(len(labs)), key=lambda i: names.index(labs[i]))   # base first
    ax.legend([handles[i] for i in order_k], [labs[i] for i in order_k], loc="lower left",
              bbox_to_anchor=(0, 1), ncol=len(pats), frameon=False, fontsize=9)
    if title:
        fig.suptitle(title, fontsize=10, y=0.995)
    buf = io.BytesIO()
    fig.savefig(buf, format="png")
    plt.close(fig)
    return atomic_write_bytes(Path(path), buf.getvalue())
