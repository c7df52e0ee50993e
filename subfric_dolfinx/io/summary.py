"""Area-weighted interface averages, resultant forces and status fractions (collective)."""

from __future__ import annotations

import numpy as np
from mpi4py import MPI

from ..constitutive import SCALAR, TANGENTIAL, Status

__all__ = ["element_summary", "interface_summary"]


def interface_summary(problem) -> dict[str, float]:
    """Area-weighted means over each interface, totals and status fractions (same on all ranks).

    With one interface the keys are those of :func:`element_summary`; with several, every key
    is prefixed by the interface's name (``head.F_n``, ``joint.F_t1``, ...).
    """
    ifaces = getattr(problem, "interfaces", None)
    if not ifaces:
        return element_summary(problem.interface, problem.law, problem.comm)
    if len(ifaces) == 1:
        iface = next(iter(ifaces.values()))
        return element_summary(iface.law_points, iface.law, problem.comm)
    out: dict[str, float] = {}
    for name, iface in ifaces.items():
        part = element_summary(iface.law_points, iface.law, problem.comm)
        out.update({f"{name}.{k}": v for k, v in part.items()})
    return out


def element_summary(el, law, comm) -> dict[str, float]:
    """Area-weighted means over one interface, totals and status fractions (collective).

    Keys: ``area``; ``F_t1`` [``F_t2``], ``F_n`` (resultant forces, the traction integrals);
    ``f_t_norm`` (mean ``|f_t|``), ``f_n`` (mean); for every output variable of the law
    (:attr:`~subfric_dolfinx.constitutive.Variable.output`), a scalar ``v`` as its mean ``v``, a
    tangential one as ``v_norm`` (mean of its magnitude) and ``v_t1`` [``v_t2``] (means of its
    components), a local one as the means of ``v_t1`` [``v_t2``], ``v_n``; and the fractions of
    quadrature points ``plastic``
    (PLASTIC or JUMP), ``separated`` and ``unstable``. With interface regions, per region
    ``<region>.area``, ``<region>.F_t1`` [``.F_t2``], ``<region>.F_n``, ``<region>.plastic`` and
    ``<region>.separated`` (region ``default``: the points of the default law).
    """
    nt = el.nt
    w = el.weights.ravel()
    st = el.state.old
    res = el.last
    tr = res.traction if res is not None else np.zeros((w.size, nt + 1))
    names = ["area", *(f"F_t{i + 1}" for i in range(nt)), "F_n", "f_t_norm"]
    cols = [w, *(w * tr[:, i] for i in range(nt + 1)), w * np.linalg.norm(tr[:, :nt], axis=1)]
    for var in law.variables:
        if not var.output:
            continue
        a = st[var.name]
        if var.shape == SCALAR:
            names.append(var.name)
            cols.append(w * a)
            continue
        if var.shape == TANGENTIAL:
            names.append(f"{var.name}_norm")
            cols.append(w * np.linalg.norm(a, axis=1))
        names += var.column_names(nt)
        cols += [w * a[:, i] for i in range(a.shape[1])]
    status = res.status if res is not None else np.full(w.size, Status.ELASTIC, np.int8)
    counts = [
        np.count_nonzero((status == Status.PLASTIC) | (status == Status.JUMP)),
        np.count_nonzero(status == Status.SEPARATED),
        np.count_nonzero(res.unstable) if res is not None else 0,
        w.size,
    ]
    loc = np.array([c.sum() for c in cols] + counts, dtype=float)
    if len(el.region_names) > 1:
        loc = np.concatenate([loc, _by_region(el, w, tr, status)])
    tot = np.zeros_like(loc)
    comm.Allreduce(loc, tot, op=MPI.SUM)
    area = tot[0]
    # resultant forces (and the area) are totals; everything else is an area-weighted mean
    out = {
        k: tot[i] if k == "area" or k.startswith("F_") else tot[i] / area
        for i, k in enumerate(names)
    }
    out["f_n"] = out["F_n"] / area
    n0 = len(names) + len(counts)
    npts = max(tot[n0 - 1], 1.0)
    out["plastic"], out["separated"], out["unstable"] = (
        tot[n0 - 4] / npts,
        tot[n0 - 3] / npts,
        tot[n0 - 2] / npts,
    )
    if len(el.region_names) > 1:
        out.update(_region_columns(el, tot[n0:]))
    return out


def _by_region(el, w: np.ndarray, tr: np.ndarray, status: np.ndarray) -> np.ndarray:
    """Local sums per region: area, the resultant (nt + 1), points, plastic, separated points."""
    region = el.point_data["region"].astype(np.int64)
    plastic = (status == Status.PLASTIC) | (status == Status.JUMP)
    rows = []
    for k in range(len(el.region_names)):
        m = region == k
        rows.append(
            [
                w[m].sum(),
                *((w[m] * tr[m, i]).sum() for i in range(el.nt + 1)),
                np.count_nonzero(m),
                np.count_nonzero(m & plastic),
                np.count_nonzero(m & (status == Status.SEPARATED)),
            ]
        )
    return np.asarray(rows, dtype=float).ravel()


def _region_columns(el, tot: np.ndarray) -> dict[str, float]:
    nt = el.nt
    out = {}
    for name, row in zip(el.region_names, tot.reshape(len(el.region_names), -1), strict=True):
        npts = max(row[nt + 2], 1.0)
        out[f"{name}.area"] = row[0]
        for i in range(nt):
            out[f"{name}.F_t{i + 1}"] = row[1 + i]
        out[f"{name}.F_n"] = row[1 + nt]
        out[f"{name}.plastic"] = row[nt + 3] / npts
        out[f"{name}.separated"] = row[nt + 4] / npts
    return out
