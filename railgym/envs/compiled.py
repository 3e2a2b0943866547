"""Calling a compiled batch step without numba's per-call type dispatch.

numba types every argument of every call to find the compiled overload; for the named tuples
of arrays of the batch kernels that costs more than a small step itself. A batch that holds
its arrays for its lifetime resolves the overload once (:func:`compiled_entry`) and calls it
directly.
"""

from __future__ import annotations

from typing import Any

import numba

__all__ = ["compiled_entry"]


def compiled_entry(fn: Any, args: tuple) -> Any:
    """Compiled entry point of the numba function ``fn`` for the types of ``args``.

    The arrays passed later must keep the dtypes, dimensions and layouts of ``args`` (the
    batch holds them for its lifetime); the entry point is not picklable, so a batch makes it
    again after a copy.

    numba's threading layer is started first: a function loaded from numba's cache that links
    a ``parallel=True`` kernel (the whole-vehicle ``advance`` does) needs the symbols of the
    parallel scheduler, which numba registers only when the layer starts.
    """
    numba.get_num_threads()
    sig = tuple(fn.typeof_pyval(a) for a in args)
    if sig not in fn.overloads:
        fn.compile(sig)
    return fn.overloads[sig].entry_point
