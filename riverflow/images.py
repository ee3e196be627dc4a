"""Writing frames to image files (Pillow: PNG encoding is not ours to write)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from riverflow._atomic import atomic_files, require_suffix


def save_png(frame: np.ndarray, path: Path | str) -> Path:
    """Write an (H, W, 4) uint8 RGBA frame as a PNG, making its folder; returns the path.

    The file appears complete or not at all (written under a temporary name, then renamed);
    a name not ending in ``.png`` is a ValueError (the extension decides the format)."""
    from PIL import Image

    path = Path(path)
    require_suffix(path, (".png",), "a frame")
    frame = np.asarray(frame)
    if frame.ndim != 3 or frame.shape[2] != 4 or frame.dtype != np.uint8:
        raise ValueError(f"save_png: frame must be an (H, W, 4) uint8 RGBA array, got "
                         f"{frame.shape} {frame.dtype}")
    with atomic_files(path) as (temp,):
        Image.fromarray(np.ascontiguousarray(frame)).save(temp)
    return path
