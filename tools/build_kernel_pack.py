"""Build riverflow's kernel pack: every recorded kernel signature compiled for a portable CPU
(x86-64-v3), written to ``riverflow/kernels/_pack/`` (:mod:`riverflow.kernels.pack`).

A wheel built afterwards carries the pack (package data), so ``pip install`` of that wheel
draws its first frame without compiling. Run it with the numba, llvmlite, numpy and Python
that the wheel will be installed with (the pack is keyed on them: with others it is ignored
and the kernels compile as without it), after any kernel edit: ``make pack``, then ``python
-m pip wheel --no-deps --no-build-isolation -w dist .``. About a minute of compile CPU (two
worker processes on the 2-core machine).

    python tools/build_kernel_pack.py [--out FOLDER] [--jobs N]
"""
from __future__ import annotations

import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from riverflow.kernels.pack import main  # noqa: E402 - the checkout's package first

if __name__ == "__main__":
    sys.exit(main())
