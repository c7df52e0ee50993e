"""Outputs and checkpoints of a finite-element run; nothing here is created unless asked for.

* :mod:`.gather`: :func:`gather_interface`, interface values of all ranks in one deterministic
  order.
* :mod:`.summary`: :func:`interface_summary`, resultant forces and area-weighted means.
* :mod:`.history`: :class:`HistoryCSV`, one row per converged step (:class:`HistoryRows`);
  :func:`write_history_file`, rows of one's own step callback with the same metadata.
* :mod:`.fields`: :class:`FieldWriter`, displacement and interface fields for ParaView;
  :mod:`.vtx`: their units written into the closed VTX files as ADIOS2 attributes.
* :mod:`.points`: :class:`InterfacePointsXDMF`, the interface state at the quadrature points
  as a point-cloud time series (XDMF/HDF5) for ParaView.
* :mod:`.interface_history`: :class:`InterfaceHistoryH5`, every interface field at every step.
* :mod:`.checkpoint`: checkpoint and restart in one HDF5 file, validated on read; the file's
  layout, format versions and validation: :mod:`.checkpoint_format`; the interfaces and the
  bulk state in it: :mod:`.checkpoint_parts`; a dynamic run's vectors: :mod:`.dynamic_state`.
* :mod:`.collective`: collective errors (:class:`OutputError`), the directory probe.
* :mod:`.outdir`: :class:`OutputDirectory`, an output directory locked for one run, its files
  known by its manifest.
* :mod:`.paths`: names made safe file names, output paths confirmed inside their directory.
* :mod:`.h5`, :mod:`.slabs`: HDF5 files written and read in per-rank slabs (h5py's MPI driver).

May import: :mod:`subfric_dolfinx.fem`, :mod:`subfric_dolfinx.constitutive`, the layer-0 modules
(:mod:`subfric_dolfinx.values`, ...), DOLFINx, MPI, h5py, ADIOS2's Python bindings (not
scenes).
"""

from .checkpoint import (
    CheckpointError,
    CheckpointWriteError,
    read_checkpoint,
    restore_checkpoint,
    write_checkpoint,
)
from .collective import OutputError, collective, probe_directory
from .fields import FieldWriter
from .gather import gather_interface, interface_of, interface_order
from .history import HistoryCSV, HistoryRows, write_history_file
from .interface_history import InterfaceHistoryH5
from .outdir import OutputDirectory
from .points import InterfacePointsXDMF, PointCloudError
from .summary import element_summary, interface_summary

__all__ = [
    "CheckpointError",
    "CheckpointWriteError",
    "FieldWriter",
    "HistoryCSV",
    "HistoryRows",
    "InterfaceHistoryH5",
    "InterfacePointsXDMF",
    "OutputDirectory",
    "OutputError",
    "PointCloudError",
    "collective",
    "element_summary",
    "gather_interface",
    "interface_of",
    "interface_order",
    "interface_summary",
    "probe_directory",
    "read_checkpoint",
    "restore_checkpoint",
    "write_checkpoint",
    "write_history_file",
]
