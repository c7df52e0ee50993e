# subfric-dolfinx: DOLFINx 0.9 from Debian 13 (trixie) packages, with the project in /project.
#
#   docker build -t subfric-dolfinx .
#   docker run --rm subfric-dolfinx                       # the test suite on 2 MPI ranks
#   docker run --rm subfric-dolfinx ./run test1           # ... on 1 rank
#   docker run --rm subfric-dolfinx ./run demo            # the main demo on 2 ranks
#
# Inside the image ./run finds DOLFINx 0.9 in the system python3 and runs natively (no chroot).
# `./run docker-check` builds this file with podman and runs the default command.
FROM debian:trixie

# The package list alone comes first, so that the (slow) package layer is rebuilt only when the
# list changes. Comments and blank lines are stripped exactly as ./run does.
ARG DEBIAN_FRONTEND=noninteractive
COPY debian-packages.txt /tmp/debian-packages.txt
RUN set -eux; \
    packages=$(sed -e 's/#.*//' -e 's/[[:space:]]//g' -e '/^$/d' /tmp/debian-packages.txt); \
    apt-get update; \
    apt-get install -y --no-install-recommends $packages; \
    apt-get clean; \
    rm -rf /var/lib/apt/lists/* /tmp/debian-packages.txt

COPY . /project
WORKDIR /project

ENV PYTHONPATH=/project \
    MPLBACKEND=Agg \
    OMP_NUM_THREADS=1 \
    OPENBLAS_NUM_THREADS=1 \
    OMPI_ALLOW_RUN_AS_ROOT=1 \
    OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1 \
    OMPI_MCA_btl=self,sm \
    H5PY_ALWAYS_USE_MPI=1

CMD ["./run", "test2"]
