"""Which numeric kernels this process runs: they decide the last bits of every table.

The BLAS library picks its kernels by CPU (OpenBLAS's AVX-512 kernels round differently from
its AVX2 ones) and NumPy its SIMD loops, so the same scenario and seed give the same tables
bit for bit only on the same kernels (docs/model.md §9). Run manifests record them.
``threadpoolctl`` finds the BLAS NumPy loaded, whichever it is (a wheel's OpenBLAS, MKL, a
system library). :data:`PINNED_ENV`, set before Python starts, makes any x86-64 CPU with AVX2
and FMA run the same kernels (with the same wheels): the golden tables and the committed
report are made that way.
"""

from __future__ import annotations

import functools
import importlib
import os
import shlex

import numpy as np
from threadpoolctl import threadpool_info

#: OpenBLAS's AVX2 kernels and NumPy's SIMD loops without AVX-512, whatever the x86-64 CPU;
#: read when NumPy loads, so they must be in the environment before Python starts.
PINNED_ENV = {
    "OPENBLAS_CORETYPE": "Haswell",
    "NPY_DISABLE_CPU_FEATURES": "X86_V4 AVX512_ICL AVX512_SPR",
}


def pinned() -> bool:
    """Whether this process started with :data:`PINNED_ENV`."""
    return all(os.environ.get(key) == value for key, value in PINNED_ENV.items())


def pinned_prefix() -> str:
    """``PINNED_ENV`` as a shell prefix (``"OPENBLAS_CORETYPE=Haswell … "``) when this process
    runs with it, else ``""``: what to put before a command to run it the same way."""
    if not pinned():
        return ""
    return "".join(f"{key}={shlex.quote(value)} " for key, value in PINNED_ENV.items())


@functools.cache
def numeric_kernels() -> dict[str, object]:
    """``{"blas": library and version, "blas_core": the kernels it chose (OpenBLAS's core
    name) or "unknown", "simd": NumPy's SIMD levels in use}``."""
    return {**_numpy_blas(), "simd": _numpy_simd()}


def _numpy_blas() -> dict[str, str]:
    libraries = [lib for lib in threadpool_info() if lib.get("user_api") == "blas"]
    # NumPy's own first (numpy/ or numpy.libs/): SciPy may have loaded one of its own beside it
    numpy_folder = os.path.dirname(os.path.abspath(np.__file__))
    libraries.sort(key=lambda lib: not str(lib.get("filepath", "")).startswith(numpy_folder))
    if not libraries:
        return {"blas": "unknown", "blas_core": "unknown"}
    lib = libraries[0]
    name = " ".join(str(lib[key]) for key in ("internal_api", "version") if lib.get(key))
    return {"blas": name, "blas_core": str(lib.get("architecture") or "unknown")}


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
