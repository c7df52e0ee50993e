"""Outputs and checkpoints of a finite-element run; nothing here is created unless asked for.

* :mod:`.gather`: :func:`gather_interface`, interface values of all ranks in one deterministic
  order.
* :mod:`.summary`: :func:`interface_summary`, resultant forces and area-weighted means.
* :mod:`.history`: :class:`HistoryCSV`, one row per converged step.
* :mod:`.fields`: :class:`FieldWriter`, displacement and interface fields for ParaView.
* :mod:`.points`: :class:`InterfacePointsXDMF`, the interface state at the quadrature points
  as a point-cloud time series (XDMF/HDF5) for ParaView.
* :mod:`.interface_history`: :class:`InterfaceHistoryH5`, every interface field at every step.
* :mod:`.checkpoint`: checkpoint and restart in one HDF5 file.

May import: :mod:`subfric_dolfinx.fem`, :mod:`subfric_dolfinx.constitutive`, DOLFINx, MPI, h5py
(not scenes).
"""

from .checkpoint import CheckpointError, read_checkpoint, restore_checkpoint, write_checkpoint
from .fields import FieldWriter
from .gather import gather_interface, interface_order
from .history import HistoryCSV
from .interface_history import InterfaceHistoryH5
from .points import InterfacePointsXDMF, PointCloudError
from .summary import interface_summary

__all__ = [
    "CheckpointError",
    "FieldWriter",
    "HistoryCSV",
    "InterfaceHistoryH5",
    "InterfacePointsXDMF",
    "PointCloudError",
    "gather_interface",
    "interface_order",
    "interface_summary",
    "read_checkpoint",
    "restore_checkpoint",
    "write_checkpoint",
]
