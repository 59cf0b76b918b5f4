# Shared by scripts/bootstrap and scripts/test; source it, don't run it.
# Provides: QBOND_ROOT (the repository's top directory), qbond_log, qbond_run,
# qbond_install_deps, qbond_configure_sanitized and qbond_build.

QBOND_ROOT=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
QBOND_PACKAGES_FILE="$QBOND_ROOT/scripts/packages.txt"

qbond_log() { printf '==> %s\n' "$*"; }

# Prints a command, then runs it.
qbond_run() {
  printf '+ %s\n' "$*"
  "$@"
}

# The packages listed in scripts/packages.txt, comments and blank lines removed.
qbond_packages() {
  sed -e 's/#.*//' -e 's/[[:space:]]\+/\n/g' "$QBOND_PACKAGES_FILE" | sed '/^$/d'
}

qbond_is_installed() {
  dpkg -s "$1" 2>/dev/null | grep -q '^Status: install ok installed$'
}

# Installs the packages of scripts/packages.txt that are missing, with apt-get (through sudo
# when not root). Runs 'apt-get update' only when something is to be installed.
qbond_install_deps() {
  if ! command -v dpkg >/dev/null || ! command -v apt-get >/dev/null; then
    qbond_log "no dpkg/apt-get: not Debian; skipping the install (scripts/packages.txt lists what is needed)"
    return 0
  fi
  local pkg missing=()
  while read -r pkg; do
    qbond_is_installed "$pkg" || missing+=("$pkg")
  done < <(qbond_packages)
  if [ ${#missing[@]} -eq 0 ]; then
    qbond_log "Debian packages: all $(qbond_packages | wc -l) of scripts/packages.txt installed"
    return 0
  fi
  local sudo=()
  if [ "$(id -u)" -ne 0 ]; then
    if ! command -v sudo >/dev/null; then
      qbond_log "missing packages (${missing[*]}) and not root, without sudo: run this script as root"
      return 1
    fi
    sudo=(sudo)
  fi
  qbond_log "Debian packages to install: ${missing[*]}"
  export DEBIAN_FRONTEND=noninteractive
  qbond_run "${sudo[@]}" apt-get update
  qbond_run "${sudo[@]}" env DEBIAN_FRONTEND=noninteractive \
    apt-get install -y --no-install-recommends "${missing[@]}"
}

# qbond_configure_sanitized: configures build-asan/ as the CMake preset `asan` says (clang,
# AddressSanitizer and UBSan, the readers instrumented for the fuzzers of fuzz/ too, so that the
# sanitized tests and scripts/fuzz share one build of the library), the bond kernels built for
# AVX2 alone when the CPU has it (the Release run tests the clone the CPU picks, AVX-512 where it
# exists; this one the AVX2 code, src/core/simd.hpp).
qbond_configure_sanitized() {
  local arch=()
  if grep -qw avx2 /proc/cpuinfo 2>/dev/null && grep -qw fma /proc/cpuinfo && grep -qw bmi2 /proc/cpuinfo; then
    arch=(-DQBOND_ARCH=x86-64-v3)
  fi
  (cd "$QBOND_ROOT" && qbond_run cmake --preset asan "${arch[@]}")
}

# qbond_build DIR [CMAKE ARGS...]: configures DIR from the repository and builds it on every core,
# each target's sources compiled in batches (CMake's unity build: a fresh build in two thirds of
# the time; a build directory configured by hand compiles file by file unless told).
qbond_build() {
  local dir=$1
  shift
  qbond_log "configuring and building $dir/"
  qbond_run cmake -S "$QBOND_ROOT" -B "$QBOND_ROOT/$dir" -DCMAKE_UNITY_BUILD=ON "$@"
  qbond_run cmake --build "$QBOND_ROOT/$dir" -j"$(nproc)"
}
