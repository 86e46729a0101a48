#!/usr/bin/env bash
# SPDX-License-Identifier: Apache-2.0
# Builds the .deb from a build tree and checks it (cmake/Packaging.cmake, docs/deployment.md
# "Install"):
#   tools/check-package.sh BUILD_DIR   cpack -G DEB into a scratch folder (BUILD_DIR's executables,
#                                      as built: build scanprep-server and scanprep first), then
#   - the files and their paths (dpkg-deb -c): the two executables and nothing else in usr/bin
#     (no tests or benchmarks), the systemd unit, the docs, the LICENSE and the example
#     /etc/default file, everything under usr/;
#   - the control fields (dpkg-deb -I): Package scanprep, Version = project() version, a Depends
#     from dpkg-shlibdeps that names libgrpc++;
#   - the unit: ExecStart at the installed server, loopback plaintext by default, a dynamic user,
#     the hardening options, Restart=on-failure; `systemd-analyze verify` when installed;
#   - unpacked (dpkg -x): `scanprep --version` and `scanprep-server --version` exit 0 with the
#     version, `scanprep-server --help` exits 1 (absl's convention).
#   tools/check-package.sh --self-test   the same checks on fake listings and control files with
#                                      a file missing, an extra executable, no Depends: each must
#                                      be caught (no build needed).
# Exit 0 when all hold, 1 with one line per finding.
set -euo pipefail

REQUIRED=(
  ./usr/bin/scanprep-server
  ./usr/bin/scanprep
  ./usr/lib/systemd/system/scanprep-server.service
  ./usr/share/doc/scanprep/LICENSE
  ./usr/share/doc/scanprep/README.md
  ./usr/share/doc/scanprep/deployment.md
  ./usr/share/doc/scanprep/scanprep-server.default
)
UNIT_LINES=(
  'ExecStart=/usr/bin/scanprep-server $SCANPREP_SERVER_ARGS'
  'EnvironmentFile=-/etc/default/scanprep-server'
  'DynamicUser=yes'
  'NoNewPrivileges=yes'
  'ProtectSystem=strict'
  'PrivateTmp=yes'
  'Restart=on-failure'
)
findings=()
fail() { findings+=("$1"); }

# $1: `dpkg-deb -c` output (the path is the last field).
check_listing() {
  local paths
  paths=$(awk '{print $NF}' <<<"$1")
  for want in "${REQUIRED[@]}"; do
    grep -qxF -- "$want" <<<"$paths" || fail "package: $want missing"
  done
  local bins
  bins=$(grep -E '^\./usr/bin/[^/]+$' <<<"$paths" | grep -vxF -e ./usr/bin/scanprep-server \
    -e ./usr/bin/scanprep || true)
  [[ -z $bins ]] || fail "package: executables beyond the server and the CLI: $(echo $bins)"
  local outside
  outside=$(grep -vE '^\./(usr(/.*)?)?$' <<<"$paths" || true)
  [[ -z $outside ]] || fail "package: files outside /usr: $(echo $outside)"
}

# $1: `dpkg-deb -I` output, $2: the expected version.
check_control() {
  local depends
  grep -qE '^ Package: scanprep$' <<<"$1" || fail "control: Package is not scanprep"
  grep -qE "^ Version: ${2//./\\.}\$" <<<"$1" || fail "control: Version is not $2"
  depends=$(sed -n 's/^ Depends: *//p' <<<"$1")
  [[ -n $depends ]] || fail "control: no Depends (dpkg-shlibdeps did not run)"
  [[ $depends == *libgrpc++* ]] || fail "control: Depends does not name libgrpc++: '$depends'"
}

# $1: the unit's text.
check_unit() {
  for want in "${UNIT_LINES[@]}"; do
    grep -qxF -- "$want" <<<"$1" || fail "unit: no line '$want'"
  done
  grep -qE '^Environment="SCANPREP_SERVER_ARGS=--plaintext --listen=127\.0\.0\.1:' <<<"$1" ||
    fail "unit: the default SCANPREP_SERVER_ARGS is not plaintext on loopback"
}

report() {
  for line in "${findings[@]}"; do echo "$line"; done
  if ((${#findings[@]})); then exit 1; fi
}

if [[ ${1:-} == --self-test ]]; then
  good_listing=$(printf -- '-rwxr-xr-x root/root 1 2026-01-01 00:00 %s\n' ./usr/ ./usr/bin/ \
    "${REQUIRED[@]}")
  good_control=$' Package: scanprep\n Version: 0.1.0\n'
  good_control+=' Depends: libc6 (>= 2.35), libgrpc++1.51 (>= 1.51.1)'
  good_unit=$(printf '%s\n' "${UNIT_LINES[@]}" \
    'Environment="SCANPREP_SERVER_ARGS=--plaintext --listen=127.0.0.1:50051"')
  declare -A breaks=(
    [the unit missing]="listing:$(grep -v systemd <<<"$good_listing")"
    [the LICENSE missing]="listing:$(grep -v LICENSE <<<"$good_listing")"
    [a test executable]="listing:$good_listing"$'\n''-rwxr-xr-x r/r 1 2026-01-01 00:00 ./usr/bin/tls_test'
    [a file in /opt]="listing:$good_listing"$'\n''-rw-r--r-- r/r 1 2026-01-01 00:00 ./opt/x'
    [no Depends]="control:$(grep -v Depends <<<"$good_control")"
    [Depends without gRPC]="control:${good_control/libgrpc++1.51/libfoo1}"
    [another version]="control:${good_control/0.1.0/0.2.0}"
    [no dynamic user]="unit:$(grep -v DynamicUser <<<"$good_unit")"
    [on every interface]="unit:${good_unit/127.0.0.1/0.0.0.0}"
  )
  check_listing "$good_listing"; check_control "$good_control" 0.1.0; check_unit "$good_unit"
  ((${#findings[@]} == 0)) || { report; }
  failures=()
  for name in "${!breaks[@]}"; do
    kind=${breaks[$name]%%:*} text=${breaks[$name]#*:}
    findings=()
    case $kind in
      listing) check_listing "$text" ;;
      control) check_control "$text" 0.1.0 ;;
      unit) check_unit "$text" ;;
    esac
    echo "$name: ${findings[0]:-NOT CAUGHT}"
    ((${#findings[@]})) || failures+=("self-test: '$name' was not caught")
  done
  findings=("${failures[@]}")
  report
  echo "self-test: every break caught"
  exit 0
fi

build=$(cd "${1:?usage: tools/check-package.sh BUILD_DIR | --self-test}" && pwd)
[[ -f $build/CPackConfig.cmake ]] ||
  { echo "$build/CPackConfig.cmake missing: configure first"; exit 1; }
for tool in cpack dpkg-deb dpkg-shlibdeps; do
  command -v "$tool" >/dev/null ||
    { echo "$tool not installed (dpkg-dev: tools/install-deps.sh)"; exit 1; }
done
version=$(sed -n 's/^set(CPACK_PACKAGE_VERSION "\(.*\)")$/\1/p' "$build/CPackConfig.cmake")
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT
if ! cpack -G DEB --config "$build/CPackConfig.cmake" -B "$scratch/out" \
    >"$scratch/cpack.log" 2>&1; then
  cat "$scratch/cpack.log"; echo "cpack -G DEB failed"; exit 1
fi
debs=("$scratch"/out/*.deb)
[[ -f ${debs[0]} && ${#debs[@]} -eq 1 ]] ||
  { echo "cpack made no single .deb: ${debs[*]}"; exit 1; }
deb=${debs[0]}
[[ $(basename "$deb") == scanprep_${version}_*.deb ]] ||
  fail "file name $(basename "$deb") is not scanprep_${version}_ARCH.deb"
check_listing "$(dpkg-deb -c "$deb")"
check_control "$(dpkg-deb -I "$deb")" "$version"

root=$scratch/root
dpkg -x "$deb" "$root"
unit=$root/usr/lib/systemd/system/scanprep-server.service
if [[ -f $unit ]]; then
  check_unit "$(cat "$unit")"
  if command -v systemd-analyze >/dev/null; then
    # The unit as installed, its ExecStart pointed at the unpacked server.
    sed "s#^ExecStart=/usr/bin/#ExecStart=$root/usr/bin/#" "$unit" \
      >"$scratch/scanprep-server.service"
    verify=$(systemd-analyze verify "$scratch/scanprep-server.service" 2>&1) ||
      fail "unit: systemd-analyze verify failed"
    [[ -z $verify ]] || fail "unit: systemd-analyze verify: $(echo $verify)"
  fi
fi
for bin in scanprep scanprep-server; do
  [[ -x $root/usr/bin/$bin ]] || continue
  out=$("$root/usr/bin/$bin" --version 2>&1) || fail "$bin --version exits $? (want 0)"
  [[ $out == *"$version"* ]] || fail "$bin --version says '$out', not $version"
done
if [[ -x $root/usr/bin/scanprep-server ]]; then
  rc=0; "$root/usr/bin/scanprep-server" --help >/dev/null 2>&1 || rc=$?
  ((rc == 1)) || fail "scanprep-server --help exits $rc (absl's --help exits 1)"
fi
report
count=$(dpkg-deb -f "$deb" Depends | tr ',' '\n' | wc -l)
echo "package ok: $(basename "$deb") ($count dependencies)"
