"""Overflow- and underflow-safe Euclidean norm of tangential vectors."""

import numpy as np


def tangential_norm(v: np.ndarray) -> np.ndarray:
    """Row norms of ``v`` (N, 1) or (N, 2) without squaring.

    ``sqrt(x**2 + y**2)`` overflows above about 1.3e154 and loses everything below about 1.5e-154;
    ``hypot`` scales internally and is exact to an ulp over the whole double range.
    """
    if v.shape[1] == 1:
        return np.abs(v[:, 0])
    return np.hypot(v[:, 0], v[:, 1])
