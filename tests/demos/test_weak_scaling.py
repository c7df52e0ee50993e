"""The weak-scaling benchmark (benchmarks/weak_scaling.py, issue 25 item 4).

* Its models and extrapolation: measured rows made from known per-part laws give those laws back,
  the table at 64 and 512 ranks is what the laws give by hand, and the part named first to stop
  scaling is the one the numbers say (rank 0's mesh when it outgrows a node's share, the
  distributed memory when nothing grows with the whole model).
* Its measurement, at a tiny size on the ranks the test runs on: the counts it records agree with
  what they must be independently (the pad's dofs and interface points by formula, the owned dofs
  summing to the total, GAMG's finest level being the Jacobian, a checkpoint holding at least the
  displacement); on the refined path (a coarse model written partitioned, read in parts and
  refined on the ranks) the fine dofs those of the refinement's counting formula, itself checked
  against the closed form of a tetrahedron refined uniformly.
"""

import itertools
import math

import pytest
from mpi4py import MPI

from benchmarks import fe_scaling, weak_scaling

A, B, E = 200.0, 0.004, 50.0  # MiB, MiB per dof of a rank, MiB more on rank 0
START, MESH0, F = 120.0, 60.0, 3e-4  # rank 0 with the mesh: START + MESH0 + F dofs (MiB)
K, ALPHA, BETA = 10.0, 0.7, 0.5  # set-up gathers: K dofs^ALPHA ranks^BETA bytes


def synthetic_rows(f: float = F) -> tuple[list[dict], list[list[int]]]:
    """Rows of a weak series that follow known laws exactly."""
    rows, levels = [], []
    for ranks, dofs in ((1, 10000), (1, 25000), (2, 50000), (2, 184000), (4, 100000), (8, 200000)):
        d = dofs / ranks
        iface = 0.5 * dofs ** (2 / 3)
        kry = 10.0 + 2.0 * math.log10(dofs)
        rows.append(
            {
                "ranks": ranks,
                "dofs": dofs,
                "dofs_per_rank": d,
                "interface_points": iface,
                "rss_others_mib": A + B * d if ranks > 1 else math.nan,  # no other rank: unused
                "rss_rank0_mib": A + B * d + E,
                "rss_start_mib": START,
                "rss_mesh_rank0_mib": START + MESH0 + f * dofs,
                "setup_gather_bytes": K * dofs**ALPHA * ranks**BETA if ranks > 1 else 0.0,
                "jacobian_mib": 0.002 * d,
                "gamg_mib": 0.0005 * d,
                "checkpoint_mib": 90.0 * dofs / 2.0**20,
                # the sample sort's samples: at most `ranks` of every rank, on rank 0
                "checkpoint_rank0_bytes": 48.0 * min(iface, ranks**2) if ranks > 1 else 0.0,
                "profile_bytes": 150.0 * iface,
                "gather_bytes_per_step": 1500.0 + 100.0 * ranks,
                "petsc_bytes_per_newton": 3000.0 * d ** (2 / 3) if ranks == 8 else 1.0,
                "krylov_per_newton": kry,
                "allreduce_calls_per_newton": 5.0 * kry,
                "coarse_rows": 100 if ranks == 8 else 50,
            }
        )
        levels.append([dofs, dofs // 10, dofs // 100])
    return rows, levels


@pytest.mark.serial  # arithmetic: the same on any number of ranks
def test_models_give_back_the_laws_and_extrapolate_by_hand():
    rows, levels = synthetic_rows()
    m = weak_scaling.fit_models(rows, levels)
    assert m.memory == pytest.approx((A, B), rel=1e-9)
    assert m.rank0_excess == pytest.approx(E) and m.start == pytest.approx(START)
    assert m.mesh == pytest.approx((MESH0, F, 0.0), rel=1e-9, abs=1e-12)
    assert m.setup_gather == pytest.approx((K, ALPHA, BETA), rel=1e-9)
    assert m.jacobian == pytest.approx(0.002) and m.gamg == pytest.approx(0.0005)
    assert m.checkpoint == pytest.approx(90.0) and m.checkpoint_rank0 == pytest.approx(48.0)
    assert m.interface_per_dof23 == pytest.approx(0.5) and m.profile == pytest.approx(150.0)
    assert m.gather_step == pytest.approx((1500.0, 100.0))
    assert m.petsc_halo == pytest.approx(3000.0)  # from the run on the most ranks
    assert m.krylov == pytest.approx((10.0, 2.0)) and m.reductions == pytest.approx(5.0)
    assert m.coarsening == pytest.approx(10.0) and m.coarse_rows == 100

    x = weak_scaling.extrapolate(m, 512, 1e8)
    d = 1e8 / 512
    mib = 2.0**20
    assert x["rss_mib"] == pytest.approx(A + B * d)
    assert x["rss_rank0_mib"] == pytest.approx(A + B * d + E)
    assert x["mesh_rank0_mib"] == pytest.approx(START + MESH0 + F * 1e8)  # 30,180 MiB
    assert x["setup_gather_mib"] == pytest.approx(K * 1e8**ALPHA * 512**BETA / mib)
    assert x["interface_points"] == pytest.approx(0.5 * 1e8 ** (2 / 3))
    assert x["profile_mib"] == pytest.approx(150.0 * 0.5 * 1e8 ** (2 / 3) / mib)
    # the sample sort's rows on rank 0: every interface point (107,722 < 512^2 samples); on 64
    # ranks 64^2 samples
    assert x["checkpoint_rank0_mib"] == pytest.approx(48.0 * 0.5 * 1e8 ** (2 / 3) / mib)
    x64 = weak_scaling.extrapolate(m, 64, 1e8)
    assert x64["checkpoint_rank0_mib"] == pytest.approx(48.0 * 64**2 / mib)
    # rank 0's working memory for those samples: the gathered bytes where it is not measured,
    # else the measured bytes per sample, and that is the part rank 0 carries
    assert x["sort_rank0_peak_mib"] == x["checkpoint_rank0_mib"]
    held = weak_scaling.extrapolate(
        weak_scaling.fit_models(rows, levels, sort_peak=112.0), 512, 1e8
    )
    assert held["sort_rank0_peak_mib"] == pytest.approx(112.0 * 0.5 * 1e8 ** (2 / 3) / mib)
    assert weak_scaling.parts_of(held)[weak_scaling.SORT_RANK0] == pytest.approx(
        (held["sort_rank0_peak_mib"], held["rss_rank0_mib"] + held["sort_rank0_peak_mib"])
    )
    assert x["gather_step_kib"] == pytest.approx((1500.0 + 100.0 * 512) / 1024)
    assert x["petsc_mib_per_newton"] == pytest.approx(3000.0 * d ** (2 / 3) / mib)
    assert x["krylov_per_newton"] == pytest.approx(26.0)
    assert x["reductions_per_newton"] == pytest.approx(130.0)
    assert x["gamg_levels"] == pytest.approx(7.0)  # 1e8 -> 1e2 rows by tenths: 7 levels
    assert x["checkpoint_gib"] == pytest.approx(90.0 * 1e8 / 2**30)


@pytest.mark.serial
def test_sort_rank0_peak_is_the_samples_and_their_sorted_copy():
    """What rank 0 holds per sample while io.slabs chooses the splitters (as rank 0 of 256 ranks).

    At least the gathered samples (``8 (width + 1)`` bytes each: the keys and a weight), at most,
    counted by hand, them twice (the gathered buffer and its sorted copy) and two int64 columns
    (the sort's permutation, the weights' running sums).
    """
    for width in (5, 2):
        got = weak_scaling.sort_rank0_peak_per_sample(256, width)
        row = 8.0 * (width + 1)
        assert row <= got <= 1.02 * (2 * row + 2 * 8)


@pytest.mark.serial
def test_first_to_break_is_named_by_the_numbers():
    rows, levels = synthetic_rows()
    m = weak_scaling.fit_models(rows, levels)
    table = [weak_scaling.extrapolate(m, p, n) for p, n in weak_scaling.TARGETS]
    part, why = weak_scaling.first_to_break(table, node_gib=4.0)
    # at 1e7 dofs every rank fits (rank 0's mesh: 120 + 60 + 3,000 = 3,180 MiB); at 1e8 on 64
    # ranks rank 0's mesh needs 30,180 MiB, 30,060 of them the mesh (the distributed share,
    # 200 + 0.004 * 1,562,500 = 6,450 MiB, is over too, but smaller)
    assert part.startswith("rank 0's mesh")
    assert why.startswith("29.5 GiB on one rank at 1e+08 dofs on 64 ranks, 29.4 GiB of it")
    # without the mesh growing, the first over 4 GiB is that distributed share
    rows, levels = synthetic_rows(f=0.0)
    m = weak_scaling.fit_models(rows, levels)
    table = [weak_scaling.extrapolate(m, p, n) for p, n in weak_scaling.TARGETS]
    part, why = weak_scaling.first_to_break(table, node_gib=4.0)
    assert part == "the per-rank memory of the distributed parts"
    assert why.startswith("6.3 GiB on one rank at 1e+08 dofs on 64 ranks")
    # with room for everything, the part that grows most from (64 ranks, 1e7) to (512, 1e8) is
    # named: the checkpoint's samples on rank 0, 64^2 -> 107,722 (every interface point; 26.3
    # times), before the set-up gathers, 10^0.7 * 8^0.5 = 14.2 times (a profile: 10^(2/3) = 4.6)
    part, why = weak_scaling.first_to_break(table, node_gib=1e6)
    assert part == weak_scaling.SORT_RANK0
    assert why.startswith("grows 26.3x from 1e+07 dofs on 64 ranks to 1e+08 on 512")
    for r in rows:
        r["checkpoint_rank0_bytes"] = 0.0
    m = weak_scaling.fit_models(rows, levels)
    table = [weak_scaling.extrapolate(m, p, n) for p, n in weak_scaling.TARGETS]
    part, why = weak_scaling.first_to_break(table, node_gib=1e6)
    assert part.startswith("the partitioner's gathers")
    assert why.startswith("grows 14.2x from 1e+07 dofs on 64 ranks to 1e+08 on 512")


@pytest.mark.serial
def test_refined_path_models_use_the_coarse_model():
    """Set-up gathers by the coarse model's dofs, the sample sort's splitters by the ranks, the
    conversion's."""
    rows, levels = synthetic_rows(f=0.0)
    for r in rows:
        r["coarse_dofs"] = r["dofs"] / 64.0
        coarse = r["coarse_dofs"]
        r["setup_gather_bytes"] = K * coarse**ALPHA * r["ranks"] ** BETA if r["ranks"] > 1 else 0
        r["checkpoint_others_bytes"] = 1000.0 + 40.0 * r["ranks"]
        r["convert_peak_mib"] = 100.0 + 2e-4 * coarse
        # rank 0 holds its share of the refined model only: its mesh grows with its dofs; a
        # global term moving the rows by 0.19 MiB (under NOISE_MIB) is not resolved by them
        r["rss_mesh_rank0_mib"] = START + MESH0 + 0.001 * r["dofs_per_rank"] + 1e-6 * r["dofs"]
    m = weak_scaling.fit_models(rows, levels)
    assert m.refine_factor == pytest.approx(64.0)
    assert m.setup_gather == pytest.approx((K, ALPHA, BETA), rel=1e-9)
    assert m.checkpoint_others == pytest.approx((1000.0, 40.0))
    assert m.convert == pytest.approx((100.0, 2e-4))
    assert m.mesh[1] == 0.0  # left out; the rest fitted again, within that 0.19 MiB
    assert m.mesh[0] == pytest.approx(MESH0, abs=0.2)
    assert m.mesh[2] == pytest.approx(0.001, rel=1e-2)
    x = weak_scaling.extrapolate(m, 512, 1e8)
    mib = 2.0**20
    assert x["coarse_dofs"] == pytest.approx(1e8 / 64)
    assert x["setup_gather_mib"] == pytest.approx(K * (1e8 / 64) ** ALPHA * 512**BETA / mib)
    assert x["checkpoint_others_mib"] == pytest.approx((1000.0 + 40.0 * 512) / mib)
    assert x["convert_mib"] == pytest.approx(100.0 + 2e-4 * 1e8 / 64)
    assert x["mesh_rank0_mib"] == pytest.approx(START + MESH0 + 0.001 * 1e8 / 512, abs=1.0)


@pytest.mark.serial
def test_weak_limit_by_hand():
    """Doubling the ranks at fixed dofs per rank, the first part past a node's share is named."""
    rows, levels = synthetic_rows()
    m = weak_scaling.fit_models(rows, levels)
    d = 1e8 / 512
    # rank 0's mesh: START + MESH0 + F d P > 4096 MiB from P = 128 (64: 3,930 MiB); nothing
    # else is over there (the set-up gathers: 7 MiB at 64 ranks)
    part, row, sizes = weak_scaling.weak_limit(m, d, node_gib=4.0)
    assert part.startswith("rank 0's mesh") and row["ranks"] == 128
    assert sizes[part] == pytest.approx(MESH0 + F * d * 128)
    # without the mesh growing: the set-up gathers, at the first doubling where
    # START + K (d P)^ALPHA P^BETA bytes exceed 4 GiB
    rows, levels = synthetic_rows(f=0.0)
    m = weak_scaling.fit_models(rows, levels)
    ranks = 64
    while START + K * (d * ranks) ** ALPHA * ranks**BETA / 2.0**20 <= 4096.0:
        ranks *= 2
    part, row, _ = weak_scaling.weak_limit(m, d, node_gib=4.0)
    assert part.startswith("the partitioner's gathers") and row["ranks"] == ranks == 16384
    # a rank's own share past the node at 64 ranks already: too many dofs per rank, no limit
    assert weak_scaling.weak_limit(m, 2e6, node_gib=4.0) is None


@pytest.mark.serial
def test_refined_counts_match_the_closed_form():
    """A tetrahedron refined k times: the tetrahedral grid with 2^k divisions per edge."""
    for k in range(5):
        n = 2**k
        v, e, f, t = weak_scaling.refined_counts((4, 6, 4, 1), k)
        assert v == (n + 1) * (n + 2) * (n + 3) // 6 and t == n**3
        assert v - e + f - t == 1  # a ball's Euler characteristic
    # two tetrahedra sharing a face: the counts add but for the shared face's
    v, e, f, t = weak_scaling.refined_counts((5, 9, 7, 2), 1)
    assert (v, t) == (5 + 9, 16) and v - e + f - t == 1


def test_measurement_at_a_tiny_size(shared_tmp):
    comm = MPI.COMM_WORLD
    n = 4
    r = weak_scaling.measure(comm, n, 3, shared_tmp)
    assert r["ranks"] == comm.size
    assert r["dofs"] == fe_scaling.dofs_of(n)
    assert sum(p["owned_dofs"] for p in r["per_rank"]) == r["dofs"]
    assert r["interface_points"] == 4 * n * n  # n x n quadrilaterals, 2 x 2 Gauss points
    assert r["steps"] == 3 and r["newton"] >= r["steps"]
    assert r["validity_warnings"] == 0  # the model of cluster/pad.json, within its validity
    lv = r["gamg_levels"]
    assert lv[0]["rows"] == r["dofs"]
    assert all(a["rows"] > b["rows"] for a, b in itertools.pairwise(lv))
    assert lv[0]["nz"] == sum(p["jacobian_nz"] for p in r["per_rank"])  # the finest is J
    assert r["checkpoint_bytes"] > 8 * r["dofs"]  # at least the displacement
    assert not r["mpi_counted"] and all(p["mpi"] == {} for p in r["per_rank"])
    if comm.size == 1:
        assert r["per_rank"][0]["pairing_received"] == 0
    row = weak_scaling.row_of(r)
    assert row["dofs_per_rank"] == pytest.approx(r["dofs"] / comm.size)
    assert row["rss_max_mib"] >= row["rss_others_mib"] > 0
    assert row["jacobian_mib"] > 0 and row["krylov_per_newton"] > 0
    assert row["gamg_complexity"] > 1.0  # the coarser levels' nonzeros come on top of J's


def test_refined_measurement_at_a_tiny_size(shared_tmp):
    comm = MPI.COMM_WORLD
    n, k = 2, 1
    info = weak_scaling.convert_one(n, shared_tmp, comm)
    path = weak_scaling.coarse_file(shared_tmp, n)
    r = weak_scaling.measure(comm, n, 3, shared_tmp, (path, k))
    assert r["path"] == "refined" and r["refine"] == k and r["ranks"] == comm.size
    assert r["coarse_dofs"] == info["coarse_dofs"] == 3 * info["counts"][0]
    assert r["dofs"] == info["fine_dofs"][k]  # the counting formula, independently
    assert sum(p["owned_dofs"] for p in r["per_rank"]) == r["dofs"]
    assert r["steps"] == 3 and r["newton"] >= r["steps"]
    assert r["validity_warnings"] == 0
    assert all(p["mpi"] == {} for p in r["per_rank"])  # no counting library preloaded
    assert all(0 < p["rss_read_mib"] <= p["rss_mesh_mib"] for p in r["per_rank"])
    row = weak_scaling.row_of(r)
    assert row["path"] == "refined" and row["coarse_dofs"] == r["coarse_dofs"]
    assert row["read_gather_bytes"] == 0.0 and row["refine_gather_bytes"] == 0.0
