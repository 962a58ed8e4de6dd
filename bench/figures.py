"""The common finish of the benchmark figures: grid, legend, title, PNG, Markdown line."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt


def save_figure(fig, axes, out: Path, title: str, alt: str, title_size: int = 10) -> str:
    """Grid every axis, legend and title on the first, write ``out`` (80 dpi) and return the
    Markdown line embedding it from docs/."""
    for axis in axes:
        axis.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[0].set_title(title, fontsize=title_size)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=80)
    plt.close(fig)
    return f"![{alt}](figures/{out.name})"
