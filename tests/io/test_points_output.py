"""The interface state at the quadrature points as a point cloud (XDMF + HDF5), read back.

The XDMF text is parsed (a temporal collection of polyvertex grids, as ParaView reads it), every
DataItem is resolved in the HDF5 file with plain h5py, and the values of every step are compared
with the interface state gathered (:func:`gather_interface`) at that step, point by point in the
gathered order; on 1 and 2 ranks. Errors are the same on every rank.
"""

import json
import xml.etree.ElementTree as ET

import h5py
import numpy as np
import pytest
from mpi4py import MPI

from subfric_dolfinx.constitutive import Status
from subfric_dolfinx.fem import FrictionSolver, LoadStepper, StepControl
from subfric_dolfinx.io import InterfacePointsXDMF, PointCloudError, gather_interface
from subfric_dolfinx.io.gather import interface_order
from subfric_dolfinx.logs import PenetrationWarning, SlideWarning
from tests.helpers import (
    DEMO_SLIDES,
    SEC7_PENALTY,
    block_problem,
    on_root,
    prefix,
    raised_on_every_rank,
)


def gathered(prob):
    """The interface state now, gathered in the documented order (every rank)."""
    el = prob.interface
    nt = el.nt
    tr = el.last.traction
    values = {"f_t": tr[:, :nt], "f_n": tr[:, nt], "status": el.last.status}
    values.update(dict(el.state.old.items()))
    return gather_interface(el, values)


def read_back(xdmf):
    """Times and {name: array (p, ...)} per step, and the geometry, from the XDMF and HDF5."""
    root = ET.parse(xdmf).getroot()
    collection = root.find("Domain/Grid")
    assert collection.get("CollectionType") == "Temporal"
    h5 = xdmf.with_suffix(".h5")
    times, steps, geometry = [], [], None
    with h5py.File(h5, "r") as f:

        def data(item):
            dims = tuple(int(d) for d in item.get("Dimensions").split())
            assert item.get("Format") == "HDF"
            name, path = item.text.strip().split(":")
            assert name == h5.name
            a = f[path][()]
            assert a.shape == dims, (path, a.shape, dims)
            return a

        for grid in collection.findall("Grid"):
            times.append(float(grid.find("Time").get("Value")))
            topo = grid.find("Topology")
            assert topo.get("TopologyType") == "Polyvertex"
            conn = data(topo.find("DataItem"))
            assert np.array_equal(conn[:, 0], np.arange(int(topo.get("NumberOfElements"))))
            geometry = data(grid.find("Geometry/DataItem"))
            attrs = grid.findall("Attribute")
            steps.append({a.get("Name"): data(a.find("DataItem")) for a in attrs})
            for a in attrs:  # every array says its unit, in the XDMF and in the HDF5 file
                if a.get("Name") == "rank":
                    continue
                unit = a.find("Information").get("Value")
                path = a.find("DataItem").text.strip().split(":")[1]
                assert f[path].attrs["unit"] == unit != "?", (a.get("Name"), unit)
            assert float(f[f"/{grid.get('Name')}"].attrs["time"]) == times[-1]
    return times, steps, geometry


@pytest.mark.leaves_validity(PenetrationWarning, reason=SEC7_PENALTY)
def test_quadrature_point_cloud_read_back_against_the_gathered_state(shared_tmp):
    comm = MPI.COMM_WORLD
    prob = block_problem(comm, partitioner="together")  # the interface on both ranks
    el = prob.interface
    solver = FrictionSolver(prob, prefix("pts"))
    expected = []
    path = shared_tmp / "points" / "interface_points.xdmf"
    with InterfacePointsXDMF(path, prob) as writer:

        def on_step(rec):
            writer.write(rec.t)
            expected.append((rec.t, gathered(prob)))

        LoadStepper(solver, 0.25, control=StepControl(dt_max=0.5), on_step=on_step).run(t_end=4.0)
    solver.destroy()
    p = comm.allreduce(el.n_elements * el.nq)

    def check():
        times, steps, x = read_back(path)
        assert times == [t for t, _ in expected]  # every step, exactly its time
        assert x.shape == (p, 2)
        order = interface_order(x, el.coordinate_tolerance)
        ref0 = expected[0][1]
        np.testing.assert_allclose(x[order], ref0["x"], rtol=0, atol=1e-12)
        plastic = 0
        for (_, ref), got in zip(expected, steps, strict=True):
            assert set(got) >= {
                "f_t1",
                "f_n",
                "traction_global",
                "status",
                "up_t1",
                "mu",
                "r",
                "up_global",
                "rank",
            }
            assert not [k for k in got if k.startswith(("state_", "f_t2")) or k == "f"], got
            g = {k: v[order] for k, v in got.items()}
            np.testing.assert_array_equal(g["f_t1"], ref["f_t"][:, 0])
            np.testing.assert_array_equal(g["f_n"], ref["f_n"])
            np.testing.assert_array_equal(g["up_t1"], ref["up"][:, 0])
            np.testing.assert_array_equal(g["mu"], ref["mu"])
            np.testing.assert_array_equal(g["r"], ref["r"])
            np.testing.assert_array_equal(g["status"], ref["status"])
            # the global traction vector: |traction| = |(f_t, f_n)|, zero third component
            np.testing.assert_allclose(
                np.linalg.norm(g["traction_global"], axis=1),
                np.hypot(ref["f_t"][:, 0], ref["f_n"]),
                rtol=1e-12,
                atol=1e-12,
            )
            assert np.all(g["traction_global"][:, 2] == 0.0)
            np.testing.assert_allclose(  # the slip vector: |up_global| = |up_t1|
                np.linalg.norm(g["up_global"], axis=1), np.abs(ref["up"][:, 0]), atol=1e-14
            )
            plastic += int(np.sum(ref["status"] == Status.PLASTIC))
        # something happened: sliding steps, and the ranks' slabs cover every point
        assert plastic > 0 and len(times) >= 6
        with h5py.File(path.with_suffix(".h5"), "r") as f:  # the vocabulary of every file
            units = json.loads(f.attrs["units"])
            assert units["f_n"] == "MPa" and units["up_t1"] == "mm" and units["r"] == "1"
            legend = json.loads(f.attrs["status_legend"])
            assert legend[str(int(Status.SEPARATED))].startswith("SEPARATED: ")
            assert "outward normal" in f.attrs["frame"]
        ranks = steps[0]["rank"]
        assert sorted(set(ranks.tolist())) == list(range(comm.size))

    on_root(comm, check)


def test_a_point_cloud_error_is_raised_on_every_rank(shared_tmp):
    comm = MPI.COMM_WORLD
    prob = block_problem(comm)
    blocker = shared_tmp / "a_file"
    if comm.rank == 0:
        blocker.write_text("not a directory")
    comm.Barrier()
    with raised_on_every_rank(PointCloudError, "interface point output: rank 0"):
        InterfacePointsXDMF(blocker / "interface_points.xdmf", prob)


@pytest.mark.parametrize("where", ["_values", "_write_slab"])
def test_a_write_failing_on_one_rank_fails_on_every_rank(shared_tmp, monkeypatch, where):
    """A write that fails on the last rank only, before the collective calls (the values) or in
    its own data transfer (the slab): every rank raises the same error, nobody waits, and the
    file is closed (a later write is refused alike)."""
    comm = MPI.COMM_WORLD
    prob = block_problem(comm)
    writer = InterfacePointsXDMF(shared_tmp / "interface_points.xdmf", prob)
    solver = FrictionSolver(prob, prefix("pts_err"))
    solver.solve(0.25, 0.25)
    prob.commit()
    writer.write(0.25)
    if comm.rank == comm.size - 1:

        def broken(self, *args):
            raise OSError("disk on fire")

        monkeypatch.setattr(InterfacePointsXDMF, where, broken)
    last = comm.size - 1
    with raised_on_every_rank(PointCloudError, f"rank {last}: OSError: disk on fire"):
        writer.write(0.5)
    with raised_on_every_rank(PointCloudError, "is closed"):
        writer.write(0.75)
    solver.destroy()


@pytest.mark.leaves_validity(SlideWarning, reason=DEMO_SLIDES)
@pytest.mark.serial
def test_the_xdmf_of_a_scene_with_fields_lists_every_step(shared_tmp):
    """Fields asked for in a scene: the point cloud is written beside the facet averages."""
    from subfric_dolfinx.scenes import run_scene
    from tests.helpers import small_scene

    s = small_scene()
    s["solver"]["prefix"] = None
    s["outputs"] = {"fields": "xdmf", "field_times": [1.0, 4.0, 9.0]}
    run_scene(s, outdir=shared_tmp, comm=MPI.COMM_WORLD)
    times, steps, _ = read_back(shared_tmp / "fields" / "interface_points.xdmf")
    assert times == [1.0, 4.0, 9.0]
    assert (shared_tmp / "fields" / "interface.xdmf").is_file()
    assert np.all(steps[2]["mu"] > 1.2 * steps[1]["mu"])  # recovered in the hold (t = 4 -> 9)
