"""numba's ``njit`` for every compiled kernel: cached on disk where numba can write its cache.

numba keeps compiled kernels beside the source (``__pycache__``) or in the user's cache folder
(``NUMBA_CACHE_DIR``). A system install run by an account that can write neither (a service
account without a home) made ``cache=True`` fail at import; there the kernels are compiled in the
process instead, each run paying the compilation.
"""

import numba


def njit(**options):
    """``numba.njit(cache=True, **options)``, or without the cache where numba has none to write."""

    def compile_(function):
        try:
            return numba.njit(cache=True, **options)(function)
        except RuntimeError as exc:
            if "cannot cache" not in str(exc):
                raise
            return numba.njit(**options)(function)

    return compile_
