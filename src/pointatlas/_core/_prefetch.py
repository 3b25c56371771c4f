"""Software prefetching for numba kernels (an ``llvm.prefetch`` intrinsic).

Kernels that read scattered memory (rows of neighbour tables visited in a
spatial order, union-find parents, heap nodes) hide the latency by asking for
the cache line a few steps before they need it. numba has no prefetch builtin,
so this module defines one. Only a hint: results never depend on it. Under
``NUMBA_DISABLE_JIT`` the functions are no-ops.
"""

from __future__ import annotations

import numba
from llvmlite import ir
from numba import types
from numba.core import cgutils
from numba.extending import intrinsic

__all__ = ["prefetch_read", "prefetch_row", "prefetch_write"]


def _make_prefetch(write: bool, with_col: bool):
    """An intrinsic ``f(arr, row, col)`` (2-D arrays) or ``f(arr, row)`` (any array,
    the start of row ``row``) prefetching that cache line for reading or writing."""
    if numba.config.DISABLE_JIT:
        if with_col:

            def noop2(arr, row, col):
                return None

            return noop2

        def noop(arr, row):
            return None

        return noop

    def _codegen(context, builder, signature, args):
        aryty = signature.args[0]
        ary = context.make_array(aryty)(context, builder, args[0])
        strides = cgutils.unpack_tuple(builder, ary.strides)
        r = context.cast(builder, args[1], signature.args[1], types.intp)
        off = builder.mul(r, strides[0])
        if with_col:
            c = context.cast(builder, args[2], signature.args[2], types.intp)
            off = builder.add(off, builder.mul(c, strides[1]))
        i8p = ir.IntType(8).as_pointer()
        ptr = builder.gep(builder.bitcast(ary.data, i8p), [off])
        i32 = ir.IntType(32)
        fnty = ir.FunctionType(ir.VoidType(), [i8p, i32, i32, i32])
        fn = cgutils.get_or_insert_function(builder.module, fnty, "llvm.prefetch.p0")
        builder.call(fn, [ptr, i32(1 if write else 0), i32(3), i32(1)])
        return context.get_dummy_value()

    if with_col:

        @intrinsic
        def _prefetch2(typingctx, arr, row, col):
            if not isinstance(arr, types.Array) or arr.ndim != 2:
                return None
            return types.void(arr, row, col), _codegen

        return _prefetch2

    @intrinsic
    def _prefetch1(typingctx, arr, row):
        if not isinstance(arr, types.Array):
            return None
        return types.void(arr, row), _codegen

    return _prefetch1


#: prefetch arr[row, col] of a 2-D array for reading
prefetch_read = _make_prefetch(False, True)
#: prefetch arr[row, col] of a 2-D array for writing
prefetch_write = _make_prefetch(True, True)
#: prefetch the start of row ``row`` of any array for reading
prefetch_row = _make_prefetch(False, False)
