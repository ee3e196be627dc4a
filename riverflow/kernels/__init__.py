"""riverflow.kernels: the numba kernels (no esper, no pyglet).

Importing this package first puts riverflow's cache locator in front of numba's
(:mod:`riverflow.kernels._cache`): every kernel module's machine code is kept in a per-user
folder keyed by the sources it is compiled from, so an edit of a helper in another module
can never load stale code.
"""
from riverflow.kernels._cache import install as _install

_install()
