/* Counts of the MPI collectives a process calls and the bytes they move (PMPI interposition).
 *
 * benchmarks/weak_scaling.py builds it (mpicc -shared -fPIC) and preloads it into the ranks
 * (mpirun -x LD_PRELOAD=...): every call of the functions below, from mpi4py, DOLFINx or PETSc,
 * is counted, then passed on to PMPI. Python reads and resets the counters through ctypes
 * (mpi_counts_read, mpi_counts_reset). Bytes are those this rank contributes (reductions,
 * broadcasts from the root: count x type size) or receives (gathers, all-to-all and neighbour
 * exchanges: the sum of its receive counts); point-to-point traffic is not counted here (PETSc
 * logs its own messages).
 */
#include <mpi.h>

enum { ALLREDUCE, REDUCE, BCAST, ALLGATHER, ALLGATHERV, GATHER, GATHERV, ALLTOALL, ALLTOALLV,
       NEIGHBOR_ALLTOALLV, SCAN, BARRIER, NFUNC };
static const char *names[NFUNC] = {"Allreduce", "Reduce", "Bcast", "Allgather", "Allgatherv",
    "Gather", "Gatherv", "Alltoall", "Alltoallv", "Neighbor_alltoallv", "Scan", "Barrier"};
static double calls[NFUNC], bytes[NFUNC];

static double tsize(MPI_Datatype t) {
    int s = 0;
    PMPI_Type_size(t, &s);
    return (double)s;
}
static double csize(MPI_Comm c) {
    int s = 1;
    PMPI_Comm_size(c, &s);
    return (double)s;
}
static double crank(MPI_Comm c) {
    int r = 0;
    PMPI_Comm_rank(c, &r);
    return (double)r;
}
static double sum_counts(const int *counts, int n) {
    double s = 0;
    for (int i = 0; i < n; i++) s += counts[i];
    return s;
}

int mpi_counts_n(void) { return NFUNC; }
const char *mpi_counts_name(int i) { return (i >= 0 && i < NFUNC) ? names[i] : ""; }
void mpi_counts_read(double *c, double *b) {
    for (int i = 0; i < NFUNC; i++) { c[i] = calls[i]; b[i] = bytes[i]; }
}
void mpi_counts_reset(void) {
    for (int i = 0; i < NFUNC; i++) calls[i] = bytes[i] = 0;
}

#define COUNT(k, nb) do { calls[k] += 1; bytes[k] += (nb); } while (0)

int MPI_Allreduce(const void *s, void *r, int n, MPI_Datatype t, MPI_Op o, MPI_Comm c) {
    COUNT(ALLREDUCE, n * tsize(t));
    return PMPI_Allreduce(s, r, n, t, o, c);
}
int MPI_Reduce(const void *s, void *r, int n, MPI_Datatype t, MPI_Op o, int root, MPI_Comm c) {
    COUNT(REDUCE, n * tsize(t));
    return PMPI_Reduce(s, r, n, t, o, root, c);
}
int MPI_Scan(const void *s, void *r, int n, MPI_Datatype t, MPI_Op o, MPI_Comm c) {
    COUNT(SCAN, n * tsize(t));
    return PMPI_Scan(s, r, n, t, o, c);
}
int MPI_Exscan(const void *s, void *r, int n, MPI_Datatype t, MPI_Op o, MPI_Comm c) {
    COUNT(SCAN, n * tsize(t));
    return PMPI_Exscan(s, r, n, t, o, c);
}
int MPI_Bcast(void *b, int n, MPI_Datatype t, int root, MPI_Comm c) {
    COUNT(BCAST, n * tsize(t));
    return PMPI_Bcast(b, n, t, root, c);
}
int MPI_Barrier(MPI_Comm c) {
    COUNT(BARRIER, 0.0);
    return PMPI_Barrier(c);
}
int MPI_Allgather(const void *s, int sn, MPI_Datatype st, void *r, int rn, MPI_Datatype rt,
                  MPI_Comm c) {
    COUNT(ALLGATHER, rn * tsize(rt) * csize(c));
    return PMPI_Allgather(s, sn, st, r, rn, rt, c);
}
int MPI_Allgatherv(const void *s, int sn, MPI_Datatype st, void *r, const int rn[],
                   const int d[], MPI_Datatype rt, MPI_Comm c) {
    COUNT(ALLGATHERV, sum_counts(rn, (int)csize(c)) * tsize(rt));
    return PMPI_Allgatherv(s, sn, st, r, rn, d, rt, c);
}
int MPI_Gather(const void *s, int sn, MPI_Datatype st, void *r, int rn, MPI_Datatype rt,
               int root, MPI_Comm c) {
    COUNT(GATHER, crank(c) == root ? rn * tsize(rt) * csize(c) : sn * tsize(st));
    return PMPI_Gather(s, sn, st, r, rn, rt, root, c);
}
int MPI_Gatherv(const void *s, int sn, MPI_Datatype st, void *r, const int rn[], const int d[],
                MPI_Datatype rt, int root, MPI_Comm c) {
    COUNT(GATHERV, crank(c) == root ? sum_counts(rn, (int)csize(c)) * tsize(rt) : sn * tsize(st));
    return PMPI_Gatherv(s, sn, st, r, rn, d, rt, root, c);
}
int MPI_Alltoall(const void *s, int sn, MPI_Datatype st, void *r, int rn, MPI_Datatype rt,
                 MPI_Comm c) {
    COUNT(ALLTOALL, rn * tsize(rt) * csize(c));
    return PMPI_Alltoall(s, sn, st, r, rn, rt, c);
}
int MPI_Alltoallv(const void *s, const int sn[], const int sd[], MPI_Datatype st, void *r,
                  const int rn[], const int rd[], MPI_Datatype rt, MPI_Comm c) {
    COUNT(ALLTOALLV, sum_counts(rn, (int)csize(c)) * tsize(rt));
    return PMPI_Alltoallv(s, sn, sd, st, r, rn, rd, rt, c);
}
static double neighbor_bytes(const int rn[], MPI_Datatype rt, MPI_Comm c) {
    int indeg = 0, outdeg = 0, weighted = 0, topo = MPI_UNDEFINED;
    PMPI_Topo_test(c, &topo);
    if (topo != MPI_DIST_GRAPH) return 0.0;
    PMPI_Dist_graph_neighbors_count(c, &indeg, &outdeg, &weighted);
    return sum_counts(rn, indeg) * tsize(rt);
}
int MPI_Neighbor_alltoallv(const void *s, const int sn[], const int sd[], MPI_Datatype st,
                           void *r, const int rn[], const int rd[], MPI_Datatype rt, MPI_Comm c) {
    COUNT(NEIGHBOR_ALLTOALLV, neighbor_bytes(rn, rt, c));
    return PMPI_Neighbor_alltoallv(s, sn, sd, st, r, rn, rd, rt, c);
}
int MPI_Ineighbor_alltoallv(const void *s, const int sn[], const int sd[], MPI_Datatype st,
                            void *r, const int rn[], const int rd[], MPI_Datatype rt, MPI_Comm c,
                            MPI_Request *q) {
    COUNT(NEIGHBOR_ALLTOALLV, neighbor_bytes(rn, rt, c));
    return PMPI_Ineighbor_alltoallv(s, sn, sd, st, r, rn, rd, rt, c, q);
}

#if MPI_VERSION >= 4
/* The large-count variants (MPI 4), which mpi4py calls where the library has them. */
static double sum_counts_c(const MPI_Count *counts, int n) {
    double s = 0;
    for (int i = 0; i < n; i++) s += (double)counts[i];
    return s;
}
int MPI_Allreduce_c(const void *s, void *r, MPI_Count n, MPI_Datatype t, MPI_Op o, MPI_Comm c) {
    COUNT(ALLREDUCE, n * tsize(t));
    return PMPI_Allreduce_c(s, r, n, t, o, c);
}
int MPI_Reduce_c(const void *s, void *r, MPI_Count n, MPI_Datatype t, MPI_Op o, int root,
                 MPI_Comm c) {
    COUNT(REDUCE, n * tsize(t));
    return PMPI_Reduce_c(s, r, n, t, o, root, c);
}
int MPI_Scan_c(const void *s, void *r, MPI_Count n, MPI_Datatype t, MPI_Op o, MPI_Comm c) {
    COUNT(SCAN, n * tsize(t));
    return PMPI_Scan_c(s, r, n, t, o, c);
}
int MPI_Exscan_c(const void *s, void *r, MPI_Count n, MPI_Datatype t, MPI_Op o, MPI_Comm c) {
    COUNT(SCAN, n * tsize(t));
    return PMPI_Exscan_c(s, r, n, t, o, c);
}
int MPI_Bcast_c(void *b, MPI_Count n, MPI_Datatype t, int root, MPI_Comm c) {
    COUNT(BCAST, n * tsize(t));
    return PMPI_Bcast_c(b, n, t, root, c);
}
int MPI_Allgather_c(const void *s, MPI_Count sn, MPI_Datatype st, void *r, MPI_Count rn,
                    MPI_Datatype rt, MPI_Comm c) {
    COUNT(ALLGATHER, rn * tsize(rt) * csize(c));
    return PMPI_Allgather_c(s, sn, st, r, rn, rt, c);
}
int MPI_Allgatherv_c(const void *s, MPI_Count sn, MPI_Datatype st, void *r, const MPI_Count rn[],
                     const MPI_Aint d[], MPI_Datatype rt, MPI_Comm c) {
    COUNT(ALLGATHERV, sum_counts_c(rn, (int)csize(c)) * tsize(rt));
    return PMPI_Allgatherv_c(s, sn, st, r, rn, d, rt, c);
}
int MPI_Gather_c(const void *s, MPI_Count sn, MPI_Datatype st, void *r, MPI_Count rn,
                 MPI_Datatype rt, int root, MPI_Comm c) {
    COUNT(GATHER, crank(c) == root ? rn * tsize(rt) * csize(c) : sn * tsize(st));
    return PMPI_Gather_c(s, sn, st, r, rn, rt, root, c);
}
int MPI_Gatherv_c(const void *s, MPI_Count sn, MPI_Datatype st, void *r, const MPI_Count rn[],
                  const MPI_Aint d[], MPI_Datatype rt, int root, MPI_Comm c) {
    COUNT(GATHERV,
          crank(c) == root ? sum_counts_c(rn, (int)csize(c)) * tsize(rt) : sn * tsize(st));
    return PMPI_Gatherv_c(s, sn, st, r, rn, d, rt, root, c);
}
int MPI_Alltoall_c(const void *s, MPI_Count sn, MPI_Datatype st, void *r, MPI_Count rn,
                   MPI_Datatype rt, MPI_Comm c) {
    COUNT(ALLTOALL, rn * tsize(rt) * csize(c));
    return PMPI_Alltoall_c(s, sn, st, r, rn, rt, c);
}
int MPI_Alltoallv_c(const void *s, const MPI_Count sn[], const MPI_Aint sd[], MPI_Datatype st,
                    void *r, const MPI_Count rn[], const MPI_Aint rd[], MPI_Datatype rt,
                    MPI_Comm c) {
    COUNT(ALLTOALLV, sum_counts_c(rn, (int)csize(c)) * tsize(rt));
    return PMPI_Alltoallv_c(s, sn, sd, st, r, rn, rd, rt, c);
}
#endif
