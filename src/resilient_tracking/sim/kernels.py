"""Which numeric kernels this process runs: they decide the last bits of every table.

OpenBLAS picks its kernels by CPU (an AVX-512 kernel rounds differently from an AVX2 one) and
NumPy its SIMD loops, so the same scenario and seed give the same tables bit for bit only on
the same kernels (docs/model.md §9). Run manifests record them.
"""

from __future__ import annotations

import ctypes
import functools
import glob
import importlib
import os

import numpy as np

#: OpenBLAS's "which kernels" query, by the symbol names NumPy's bundled builds use
_CORENAME_SYMBOLS = (
    "scipy_openblas_get_corename64_",
    "scipy_openblas_get_corename",
    "openblas_get_corename64_",
    "openblas_get_corename",
)


@functools.cache
def numeric_kernels() -> dict[str, object]:
    """``{"openblas": core name or "unknown", "simd": NumPy's SIMD levels in use}``."""
    return {"openblas": _openblas_core(), "simd": _numpy_simd()}


def _openblas_core() -> str:
    folder = os.path.join(os.path.dirname(np.__file__), os.pardir, "numpy.libs")
    for path in sorted(glob.glob(os.path.join(folder, "*openblas*"))):
        try:
            library = ctypes.CDLL(path)
        except OSError:
            continue
        for symbol in _CORENAME_SYMBOLS:
            query = getattr(library, symbol, None)
            if query is not None:
                query.restype = ctypes.c_char_p
                return str(query().decode())
    return "unknown"


def _numpy_simd() -> list[str]:
    features: dict[str, bool] = {}
    for module in ("numpy._core._multiarray_umath", "numpy.core._multiarray_umath"):  # 2.x, 1.x
        try:
            features = importlib.import_module(module).__cpu_features__
            break
        except (ImportError, AttributeError):
            continue
    groups = ("X86_V", "AVX512", "ASIMD", "SVE", "VSX")
    return sorted(name for name, on in features.items() if on and name.startswith(groups))
