# subfric-dolfinx on Debian packages, with the project in /project. Two stacks (see ./run):
#   trixie (default): Debian 13, DOLFINx 0.9.0, PETSc 3.22, Python 3.13
#   sid:              Debian unstable, DOLFINx 0.11.0, PETSc 3.25, Python 3.14
#
#   docker build -t subfric-dolfinx .                                  # trixie
#   docker build --build-arg STACK=sid -t subfric-dolfinx:sid .        # sid
#   docker run --rm subfric-dolfinx                       # the test suite on 2 MPI ranks
#   docker run --rm subfric-dolfinx ./run test1           # ... on 1 rank
#   docker run --rm subfric-dolfinx ./run demo            # the main demo on 2 ranks
#
# Inside the image ./run finds the stack's DOLFINx in the system python3 and runs natively (no
# chroot); SUBFRIC_STACK names the stack. `./run docker-check` builds this file for each stack
# with podman and runs the default command.
ARG STACK=trixie
FROM debian:${STACK}
ARG STACK

# The package list alone comes first, so that the (slow) package layer is rebuilt only when the
# list changes; .ci/packages reads it exactly as ./run does.
ARG DEBIAN_FRONTEND=noninteractive
COPY debian-packages.txt /tmp/subfric/debian-packages.txt
COPY .ci/packages /tmp/subfric/packages
RUN set -eux; \
    if [ "$STACK" = sid ]; then \
        # sid's Release file expires a week after it is made: a mirror serving an older
        # snapshot would be refused whole (./run explains); the signatures are still checked
        echo 'Acquire::Check-Valid-Until "false";' >/etc/apt/apt.conf.d/99subfric-sid; \
    fi; \
    packages=$(sh /tmp/subfric/packages "$STACK" /tmp/subfric/debian-packages.txt); \
    apt-get update; \
    apt-get install -y --no-install-recommends $packages; \
    apt-get clean; \
    rm -rf /var/lib/apt/lists/* /tmp/subfric

COPY . /project
WORKDIR /project

ENV SUBFRIC_STACK=${STACK} \
    PYTHONPATH=/project \
    MPLBACKEND=Agg \
    OMP_NUM_THREADS=1 \
    OPENBLAS_NUM_THREADS=1 \
    OMPI_ALLOW_RUN_AS_ROOT=1 \
    OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMPI_MCA_btl=self,sm \
    H5PY_ALWAYS_USE_MPI=1 \
    ADIOS2_ALWAYS_USE_MPI=1

CMD ["./run", "test2"]
