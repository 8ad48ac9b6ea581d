"""A CasADi solver behind one flat NumPy buffer, and silencing what CasADi's plugins print."""

from __future__ import annotations

import contextlib
import ctypes
import io
import os
from collections.abc import Iterator
from typing import Any

import casadi as ca
import numpy as np


class BufferedCall:
    """One solver behind a single flat input and output vector, evaluated in place.

    CasADi's conversion of many NumPy arguments costs more than a small solve, so the solver is
    wrapped in an MX function of one vector ``[x0, p, lbx, ubx, lam_x0, lam_g0, lbg]`` returning
    ``[x, lam_x, lam_g, f]``, evaluated through :meth:`casadi.Function.buffer` on NumPy memory.
    """

    def __init__(self, solver: ca.Function, n_x: int, n_p: int, n_g: int):
        with quiet_stdout():  # qpOASES prints a licence banner when its memory is set up
            self._setup(solver, n_x, n_p, n_g)

    def _setup(self, solver: ca.Function, n_x: int, n_p: int, n_g: int) -> None:
        self.solver = solver
        sizes = [n_x, n_p, n_x, n_x, n_x, n_g, n_g]
        z = ca.MX.sym("z", sum(sizes))
        x0, p, lbx, ubx, lam_x0, lam_g0, lbg = ca.vertsplit(z, np.cumsum([0, *sizes]).tolist())
        out = solver(
            x0=x0, p=p, lbx=lbx, ubx=ubx, lam_x0=lam_x0, lam_g0=lam_g0, lbg=lbg, ubg=ca.inf
        )
        flat = ca.vertcat(out["x"], out["lam_x"], out["lam_g"], out["f"])
        self.function = ca.Function(f"{solver.name()}_flat", [z], [flat])
        self.offsets = np.cumsum([0, *sizes])
        self.arg = np.zeros(int(self.offsets[-1]))
        self.res = np.zeros(2 * n_x + n_g + 1)
        self.n_x, self.n_g = n_x, n_g
        self.compiled = False
        buffer: Any  # the SWIG wrapper takes (index, buffer); its stub also lists a size
        buffer, self._evaluate = self.function.buffer()
        buffer.set_arg(0, self.arg.data)
        buffer.set_res(0, self.res.data)
        self._buffer = buffer
        self._first = True
        #: which of the solver's memories the wrapper uses (its stats live there)
        self.memory: int | None = None

    def __call__(self, *parts: np.ndarray) -> dict[str, np.ndarray]:
        o = self.offsets
        for k, part in enumerate(parts):
            self.arg[o[k] : o[k + 1]] = part
        if self._first:  # qpOASES prints a licence banner when its first QP is set up
            self._first = False
            with quiet_stdout():
                self._evaluate()
        else:
            self._evaluate()
        n_x, n_g, r = self.n_x, self.n_g, self.res
        return {
            "x": r[:n_x].copy(),
            "lam_x": r[n_x : 2 * n_x].copy(),
            "lam_g": r[2 * n_x : 2 * n_x + n_g].copy(),
            "f": r[2 * n_x + n_g :].copy(),
        }

    def stats(self) -> dict[str, Any]:
        """Stats of the last evaluation; ``{"success": False, ...}`` when CasADi has none."""
        if self.memory is None:
            for memory in range(8):
                try:
                    self.solver.stats(memory)
                except RuntimeError:
                    continue
                self.memory = memory
                break
        try:
            return dict(self.solver.stats(self.memory or 0))
        except RuntimeError as err:  # sqpmethod may fail to report after a QP failure
            return {"success": False, "return_status": f"no stats ({err.__class__.__name__})"}


@contextlib.contextmanager
def quiet_stdout() -> Iterator[None]:
    """Silence what CasADi's plugins print for the duration.

    CasADi routes its plugins' messages through Python's ``sys.stdout``; C code may also write
    to file descriptor 1 directly, so both are redirected.
    """
    with contextlib.redirect_stdout(io.StringIO()):
        try:
            _LIBC.fflush(None)
            saved = os.dup(1)
        except (OSError, ValueError):  # no file descriptor 1: nothing more to silence
            yield
            return
        try:
            with open(os.devnull, "w") as devnull:
                os.dup2(devnull.fileno(), 1)
                yield
        finally:
            _LIBC.fflush(None)  # drop what C stdio buffered while fd 1 was null
            os.dup2(saved, 1)
            os.close(saved)


_LIBC = ctypes.CDLL(None)
