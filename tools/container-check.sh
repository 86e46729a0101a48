#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds the Dockerfile for real without a Docker engine or a registry, and smoke-tests the
# runtime stage inside the build (podman run needs cgroup control this machine lacks).
#   1. debootstrap --variant=minbase bookworm, imported with podman as debian:bookworm, so the
#      Dockerfile's FROM resolves locally;
#   2. podman build --isolation=chroot --pull=never of the Dockerfile (its runtime stage ends with
#      `RUN scanprep-server --version`, proving every shared library is there);
#   3. a test stage that starts the server inside the image and checks its health service.
# Slow (10-20 min); CI runs tools/check-runtime-libs.sh instead. Run it after changing the
# Dockerfile, the runtime packages or the linked libraries.
set -euo pipefail
cd "$(dirname "$0")/.."
work=${CONTAINER_CHECK_DIR:-/var/tmp/scanprep-container-check}
mirror=${DEBIAN_MIRROR:-http://deb.debian.org/debian}

need=()
for p in debootstrap podman; do command -v "$p" >/dev/null || need+=("$p"); done
if ((${#need[@]})); then
  apt-get update -qq && DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
fi

start=$(date +%s)
if ! podman image exists debian:bookworm; then
  rm -rf "$work/rootfs" && mkdir -p "$work/rootfs"
  debootstrap --variant=minbase bookworm "$work/rootfs" "$mirror" >"$work/debootstrap.log"
  tar -C "$work/rootfs" -c . | podman import - debian:bookworm
fi

# Tagged with the release, CMakeLists.txt's project() version (the Dockerfile's ARG VERSION).
version=$(sed -n 's/^project(scanprep VERSION \([0-9.]*\).*/\1/p' CMakeLists.txt)
podman build --isolation=chroot --pull=never --build-arg VERSION="$version" \
  -t "scanprep:$version" -f Dockerfile .

# The smoke test: start the server in the runtime image and ask it for GetInfo. Plaintext on
# loopback inside the build; production mounts certificates and uses the --tls_* flags.
echo "FROM scanprep:$version" >"$work/Containerfile.smoke"
cat >>"$work/Containerfile.smoke" <<'SMOKE'
USER root
# The step fails unless the server answers GetInfo and then exits 0 on SIGTERM.
RUN scanprep-server --plaintext --listen=127.0.0.1:50051 --metrics_listen=127.0.0.1:9464 & pid=$! \
 ; for i in $(seq 50); do scanprep info --server=127.0.0.1:50051 >/tmp/info 2>&1 && break; sleep 0.2; done \
 ; cat /tmp/info && grep -q "stages" /tmp/info \
 && kill -TERM "$pid" && wait "$pid" && echo "smoke test passed"
SMOKE
podman build --isolation=chroot --pull=never -t scanprep:smoke -f "$work/Containerfile.smoke" "$work"
echo "container-check: image built and smoke-tested in $(( $(date +%s) - start )) s"
