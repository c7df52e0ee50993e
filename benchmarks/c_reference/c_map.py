"""Build the C reference (``return_map.c``) on the fly with gcc and call it through ctypes.

``load()`` returns a function ``c_map(params, gap, up, mu, r, f, dt)`` -> dict of arrays
(traction, tangent, up, mu, r, status, unstable, iterations, n_scan), or ``None`` with a reason
when no compiler is available (``reason()``). The C file is the package's subloading map
(``subfric_dolfinx/constitutive/_subloading``, as its scalar form was when transliterated; the
scalar form now lives in ``tests/reference_map``), without the branch-and-bound scan (points
needing it get status :data:`NEEDS_SCAN` and are counted in ``n_scan``). It lives here, not in
the package: it is a yardstick for the numpy map, not a part of it.
"""

from __future__ import annotations

import ctypes
import shutil
import subprocess
import tempfile
from pathlib import Path

import numpy as np

SRC = Path(__file__).with_name("return_map.c")
CFLAGS = ["-O2"]
_LIB = None
_REASON = ""

NEEDS_SCAN = 5
"""The C reference's status of a point that needs the branch-and-bound scan it lacks (its other
codes are :class:`~subfric_dolfinx.constitutive.Status`'s)."""


def reason() -> str:
    """Why the C reference is not available (empty if it is)."""
    return _REASON


def load(cflags: list[str] | None = None):
    """Compile (once per flag set) and return the C map, or None."""
    global _LIB, _REASON
    flags = CFLAGS if cflags is None else cflags
    cc = shutil.which("gcc") or shutil.which("cc")
    if cc is None:
        _REASON = "no C compiler (gcc/cc) on PATH: C reference skipped"
        return None
    tmp = Path(tempfile.mkdtemp(prefix="rm_c_"))
    so = tmp / "return_map.so"
    cmd = [cc, *flags, "-shared", "-fPIC", "-o", str(so), str(SRC), "-lm"]
    try:
        subprocess.run(cmd, check=True, capture_output=True, text=True)
    except subprocess.CalledProcessError as e:
        _REASON = f"compiling the C reference failed: {' '.join(cmd)}\n{e.stderr}"
        return None
    lib = ctypes.CDLL(str(so))
    dp = np.ctypeslib.ndpointer(dtype=np.float64, flags="C_CONTIGUOUS")
    fn = lib.rm_batch
    fn.restype = ctypes.c_int
    fn.argtypes = [
        dp,
        ctypes.c_int,
        ctypes.c_int,
        dp,
        dp,
        dp,
        dp,
        ctypes.c_void_p,
        ctypes.c_double,
        ctypes.c_double,
        ctypes.c_int,
        ctypes.c_double,
        dp,
        dp,
        dp,
        dp,
        dp,
        np.ctypeslib.ndpointer(dtype=np.int8, flags="C_CONTIGUOUS"),
        np.ctypeslib.ndpointer(dtype=np.uint8, flags="C_CONTIGUOUS"),
        np.ctypeslib.ndpointer(dtype=np.int64, flags="C_CONTIGUOUS"),
    ]
    _LIB = lib

    def c_map(p, gap, up, mu, r, f, dt, tol=1e-13, max_iter=100, out=None, contact_tol=1e-12):
        n, nt = up.shape
        m = nt + 1
        law = np.array(
            [p.alpha_t, p.alpha_n, p.mu_s, p.mu_k, p.kappa, p.xi, p.u_tilde, p.c_n], dtype=float
        )
        if out is None:
            out = {
                "traction": np.empty((n, m)),
                "tangent": np.empty((n, m, m)),
                "up": np.empty((n, nt)),
                "mu": np.empty(n),
                "r": np.empty(n),
                "status": np.empty(n, dtype=np.int8),
                "unstable": np.empty(n, dtype=np.uint8),
                "iterations": np.empty(n, dtype=np.int64),
            }
        fptr = None if f is None else np.ascontiguousarray(f, dtype=float).ctypes.data
        out["n_scan"] = fn(
            law,
            n,
            nt,
            np.ascontiguousarray(gap),
            np.ascontiguousarray(up),
            np.ascontiguousarray(mu),
            np.ascontiguousarray(r),
            fptr,
            float(dt),
            float(tol),
            int(max_iter),
            float(contact_tol),
            out["traction"],
            out["tangent"],
            out["up"],
            out["mu"],
            out["r"],
            out["status"],
            out["unstable"],
            out["iterations"],
        )
        return out

    c_map.command = " ".join(cmd)
    return c_map
