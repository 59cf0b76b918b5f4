#!/usr/bin/env bash
# Installs the build into a temporary prefix, then builds and runs a project outside the tree
# against it twice: with CMake's find_package(qbond) and with pkg-config.
#   install_test.sh BUILD_DIR SOURCE_DIR WORK_DIR
set -euo pipefail
build=$1 source=$2 work=$3
rm -rf "$work"
prefix=$work/prefix
cmake --install "$build" --prefix "$prefix" >/dev/null
for f in bin/qbond include/qbond/version.hpp include/qbond/simulation/simulation.hpp lib/libqbond.a \
         lib/cmake/qbond/qbondConfig.cmake lib/cmake/qbond/qbondConfigVersion.cmake lib/pkgconfig/qbond.pc \
         share/qbond/scenes/cube_drop.json share/doc/qbond/LICENSE share/doc/qbond/api.md; do
  [ -e "$prefix/$f" ] || { echo "FAIL: $prefix/$f was not installed" >&2; exit 1; }
done
"$prefix/bin/qbond" --version | grep -qx "qbond $(sed -n 's/^#define QBOND_VERSION "\(.*\)"/\1/p' "$prefix/include/qbond/version.hpp")"

# CMake package.
cmake -S "$source/tests/install/consumer" -B "$work/cmake-build" -DCMAKE_PREFIX_PATH="$prefix" -DCMAKE_BUILD_TYPE=Release >/dev/null
cmake --build "$work/cmake-build" >/dev/null
"$work/cmake-build/consumer"

# pkg-config.
export PKG_CONFIG_PATH=$prefix/lib/pkgconfig
# shellcheck disable=SC2046
c++ -std=c++20 -O1 $(pkg-config --cflags qbond) "$source/tests/install/consumer/main.cpp" -o "$work/pc-consumer" $(pkg-config --libs qbond)
"$work/pc-consumer"
echo "installed tree usable with find_package and pkg-config"
