"""PETSc calls that petsc4py 3.22 does not wrap, isolated here.

``SNESSetFunctionDomainError`` tells SNES that the residual cannot be evaluated at the current
iterate (here: a point the return map could not integrate), so that the line search backtracks or
the solve stops with ``SNES_DIVERGED_FUNCTION_DOMAIN``. petsc4py wraps it from 3.23 on
(``SNES.setFunctionDomainError``); with 3.22 it is called through ctypes from the ``libpetsc``
shared library already loaded in the process (found in ``/proc/self/maps``).

Fallback, where neither works (another OS, a static PETSc): the residual is filled with NaN, which
every SNES line search treats as a failed evaluation (``SNES_DIVERGED_FNORM_NAN`` with the basic
line search, a backtrack with ``bt``); the load stepper then cuts the step exactly as after a
domain error. :func:`domain_error_mode` says which route is in use.
"""

from __future__ import annotations

import ctypes
import functools

from petsc4py import PETSc

__all__ = ["domain_error_mode", "set_function_domain_error"]


@functools.cache
def _library() -> ctypes.CDLL | None:
    try:
        with open("/proc/self/maps") as f:
            for line in f:
                parts = line.split()
                path = parts[-1] if len(parts) >= 6 else ""
                if "libpetsc" in path and ".so" in path:
                    lib = ctypes.CDLL(path)
                    lib.SNESSetFunctionDomainError.argtypes = [ctypes.c_void_p]
                    return lib
    except (OSError, AttributeError):
        pass
    return None


def domain_error_mode() -> str:
    """``"petsc4py"``, ``"ctypes"`` or ``"nan"``: how a domain error is signalled here."""
    if hasattr(PETSc.SNES, "setFunctionDomainError"):
        return "petsc4py"
    return "ctypes" if _library() is not None else "nan"


def set_function_domain_error(snes: PETSc.SNES, F: PETSc.Vec) -> None:
    """Mark the residual being evaluated as outside the function's domain (see module docstring).

    Args:
        snes: The solver whose residual callback is running.
        F: The residual vector being filled (zeroed, or set to NaN in the fallback).
    """
    mode = domain_error_mode()
    if mode == "petsc4py":
        F.set(0.0)
        snes.setFunctionDomainError()
        return
    if mode == "ctypes":
        F.set(0.0)
        lib = _library()
        assert lib is not None  # (the mode is "ctypes": PETSc's library is found)
        err = lib.SNESSetFunctionDomainError(ctypes.c_void_p(snes.handle))
        if err == 0:
            return
    F.set(float("nan"))
