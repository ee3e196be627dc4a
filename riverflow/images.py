"""Writing frames to image files (Pillow: PNG encoding is not ours to write)."""
from __future__ import annotations

from pathlib import Path

import numpy as np


def save_png(frame: np.ndarray, path: Path | str) -> Path:
    """Write an (H, W, 4) uint8 RGBA frame as a PNG, making its folder; returns the path."""
    from PIL import Image

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    Image.fromarray(frame, "RGBA").save(path)
    return path
