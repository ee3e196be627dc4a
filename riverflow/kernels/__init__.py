"""riverflow.kernels: the numba kernels (no esper, no pyglet).

Importing this package first puts riverflow's cache locator in front of numba's
(:mod:`riverflow.kernels._cache`): every kernel module's machine code is kept in a per-user
folder keyed by the sources it is compiled from, so an edit of a helper in another module
can never load stale code. Before that, when the package ships a kernel pack that this CPU
can run, numba is set to compile for the pack's CPU target (:mod:`riverflow.kernels.pack`), so
the pack's machine code loads instead of compiling on a first run.
"""
from riverflow.kernels._cache import install as _install
from riverflow.kernels.pack import choose_target as _choose_target

_choose_target()
_install()
