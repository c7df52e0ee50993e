#!/bin/bash
# A Slurm job running a scene of subfric-dolfinx from its Apptainer image, one MPI rank per core
# (docs/reference/cluster.md):
#
#   sbatch cluster/job.sh SCENE.json OUTDIR [PETSc options ...]
#
# The PETSc options below are those that matter at scale with "linear": "gamg" (the scene's
# solver); more go after OUTDIR, under the scene's solver prefix (PREFIX, default pad_).
# Environment: IMAGE (the .sif, default subfric-dolfinx.sif), LAUNCH (how the ranks start,
# default `srun --mpi=pmix`; `mpirun -n N` outside Slurm), RUNNER (the container command before
# python3, default `apptainer exec IMAGE`; empty: the host's own DOLFINx), PYTHON (default python3).
#SBATCH --job-name=subfric
#SBATCH --nodes=2
#SBATCH --ntasks-per-node=32
#SBATCH --cpus-per-task=1
#SBATCH --mem-per-cpu=3G
#SBATCH --time=02:00:00
#SBATCH --output=%x-%j.out
# a minute before the time limit every rank gets SIGUSR1: the run stops after its step, with a
# checkpoint if the scene writes any (exit code 75; --restart OUTDIR/checkpoint.h5 continues it)
#SBATCH --signal=USR1@60
set -euo pipefail

if [ $# -lt 2 ]; then
    echo "usage: sbatch $0 SCENE.json OUTDIR [PETSc options ...]" >&2
    exit 2
fi
scene=$1 out=$2
shift 2
IMAGE=${IMAGE:-subfric-dolfinx.sif}
PREFIX=${PREFIX:-pad_}
read -r -a launch <<<"${LAUNCH:-srun --mpi=pmix}"
read -r -a runner <<<"${RUNNER-apptainer exec $IMAGE}"

# one thread per rank (BLAS and OpenMP would oversubscribe the cores Slurm gave the ranks)
export OMP_NUM_THREADS=1 OPENBLAS_NUM_THREADS=1

petsc=(
    # coarse levels gathered on fewer ranks: a coarse grid spread over every rank of a large job
    # costs more in messages than in work
    "-${PREFIX}pc_gamg_process_eq_limit" 200
    "-${PREFIX}pc_gamg_coarse_eq_limit" 1000
    # one line per Newton solve: why it stopped
    "-${PREFIX}snes_converged_reason"
)

exec "${launch[@]}" "${runner[@]}" "${PYTHON:-python3}" -m subfric_dolfinx.scenes "$scene" --out "$out" \
    "${petsc[@]}" "$@"
