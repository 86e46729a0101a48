# SPDX-License-Identifier: Apache-2.0
# Multi-stage build on Debian 12: the build stage has the -dev packages, the runtime stage only
# the shared libraries the binaries load (tools/check-runtime-libs.sh keeps the list honest).
FROM debian:bookworm AS build
RUN apt-get update \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends \
      cmake ninja-build g++ pkg-config libgrpc++-dev protobuf-compiler-grpc libprotobuf-dev \
      libabsl-dev libeigen3-dev libnanoflann-dev libtbb-dev libcpp-httplib-dev zlib1g-dev liblzf-dev \
      libcli11-dev libexpat1-dev libpng-dev \
 && rm -rf /var/lib/apt/lists/*
WORKDIR /src
COPY CMakeLists.txt ./
COPY cmake cmake
COPY proto proto
COPY wire wire
COPY core core
COPY server server
COPY client client
RUN cmake -S . -B /build -G Ninja -DCMAKE_BUILD_TYPE=Release \
      -DSCANPREP_BUILD_TESTS=OFF -DSCANPREP_BUILD_BENCHMARKS=OFF \
 && ninja -C /build scanprep-server scanprep

FROM debian:bookworm AS runtime
# The release: CMakeLists.txt's project() version, the tag the image is pushed with and the
# kustomize images: newTag (tools/check_manifests.py keeps the three equal; the RUN below checks
# the binary says the same).
ARG VERSION=0.1.0
LABEL org.opencontainers.image.title="scanprep" \
      org.opencontainers.image.description="point-cloud cleanup gRPC server (scanprep-server)" \
      org.opencontainers.image.version="${VERSION}" \
      org.opencontainers.image.licenses="Apache-2.0"
# RUNTIME_PACKAGES (read by tools/check-runtime-libs.sh)
RUN apt-get update \
 && DEBIAN_FRONTEND=noninteractive apt-get install -y --no-install-recommends \
      libgrpc++1.51 libgrpc29 libprotobuf32 libabsl20220623 libtbb12 libcpp-httplib0.11 liblzf1 libexpat1 libpng16-16 \
 && rm -rf /var/lib/apt/lists/* \
 && useradd --system --uid 10001 --no-create-home scanprep
COPY --from=build /build/server/scanprep-server /build/client/scanprep /usr/local/bin/
COPY LICENSE /usr/share/doc/scanprep/LICENSE
# Proves the runtime stage is complete: the binaries load and run, and are the version labelled.
RUN scanprep-server --version && test "$(scanprep-server --version)" = "scanprep-server ${VERSION}" \
 && scanprep --help >/dev/null
# glibc otherwise keeps a heap per thread and resident memory creeps up across jobs.
ENV MALLOC_ARENA_MAX=2
USER 10001
EXPOSE 50051 9464
ENTRYPOINT ["scanprep-server"]
# Plaintext for local trials only. Production mounts certificates and replaces --plaintext with
# --tls_cert=/certs/tls.crt --tls_key=/certs/tls.key --tls_client_ca=/certs/ca.crt (mutual TLS).
CMD ["--plaintext", "--listen=0.0.0.0:50051", "--metrics_listen=0.0.0.0:9464"]
