#!/usr/bin/env bash
# Runs every test of Avatar Studio. Installs what the tests need first (Debian/Ubuntu, as root
# or with sudo): lavapipe (software Vulkan) for the studio's screenshot tests, Node.js for the
# Khronos glTF validator, Blender and numpy (its glTF importer needs numpy, which the Debian
# package does not pull in) for the headless Blender import check (about 40 s, 680 MB), OpenMPI
# and libclang (the `mpi` feature's bindings) for the 1-vs-2-process meta-training test. After
# the tests it packages, installs and checks the .deb (packaging/build-deb.sh --binary). The
# cargo target directory lives outside the checkout so that repeated runs (and CI on the same
# machine) reuse the build.
set -euo pipefail
cd "$(dirname "$0")/.."

export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/avatar-studio/target}"
export WGPU_BACKEND="${WGPU_BACKEND:-vulkan}"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp/avatar-studio-runtime}"
mkdir -p "$XDG_RUNTIME_DIR" && chmod 0700 "$XDG_RUNTIME_DIR"

missing=()
[ -e /usr/share/vulkan/icd.d/lvp_icd.x86_64.json ] || [ -n "$(ls /usr/share/vulkan/icd.d/lvp_icd.*.json 2>/dev/null)" ] || missing+=(mesa-vulkan-drivers libvulkan1)
command -v node >/dev/null || missing+=(nodejs)
command -v npm >/dev/null || missing+=(npm)
command -v blender >/dev/null || missing+=(blender)
[ -e /usr/lib/python3/dist-packages/numpy/__init__.py ] || missing+=(python3-numpy)
command -v mpirun >/dev/null && command -v mpicc >/dev/null || missing+=(openmpi-bin libopenmpi-dev)
# (libclang-cpp, which Mesa pulls in, is not what bindgen loads.)
[ -n "$(ls /usr/lib/llvm-*/lib/libclang.so* /usr/lib/x86_64-linux-gnu/libclang.so* /usr/lib/x86_64-linux-gnu/libclang-[0-9]*.so* 2>/dev/null)" ] || missing+=(libclang-dev)
if [ ${#missing[@]} -gt 0 ]; then
  echo "installing system packages: ${missing[*]}"
  SUDO=""; [ "$(id -u)" = 0 ] || SUDO="sudo"
  log=$(mktemp)
  if ! { $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq &&
         $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${missing[@]}"; } >"$log" 2>&1; then
    tail -n 30 "$log"; echo "error: could not install ${missing[*]}" >&2; exit 1
  fi
fi

if [ -f tests/gltf-validator/package-lock.json ] && [ ! -d tests/gltf-validator/node_modules ]; then
  npm ci --prefix tests/gltf-validator --no-audit --no-fund --loglevel=error
fi

# Style gates: formatting, clippy (the workspace lint table in Cargo.toml) with warnings as
# errors, no source file over 500 lines, no import circle between module files.
cargo fmt --all --check
cargo clippy --workspace --all-targets --locked -- -D warnings
long=$(find core neural app -name '*.rs' -exec wc -l {} + | awk '$2 != "total" && $1 > 500')
if [ -n "$long" ]; then
  echo "error: source files over 500 lines (split them):" >&2; echo "$long" >&2; exit 1
fi
circles=$(python3 scripts/import_circles.py)
if ! grep -qx 'import circles: 0' <<<"$circles"; then
  echo "error: import circles between module files:" >&2; echo "$circles" >&2; exit 1
fi

cargo test --workspace --locked "$@"

# The newcomer's path (README, Layout): the three teaching examples, which `cargo test` built,
# run end to end on the demo capture (a 2-step fit; about a minute).
if [ $# -eq 0 ]; then
  examples="$CARGO_TARGET_DIR/debug/examples"
  tour=$(mktemp -d)
  "$examples/open_capture" >/dev/null
  "$examples/fit_avatar" assets/demo "$tour/me.avatar" 2 >/dev/null
  "$examples/pose_and_export" "$tour/me.avatar" walk "$tour" >/dev/null
  [ -s "$tour/posed.obj" ] && [ -s "$tour/walk.glb" ] || { echo "error: the examples wrote nothing" >&2; exit 1; }
  rm -rf "$tour"
fi

# Data-parallel meta-training over MPI (neural's `mpi` feature, off in the studio's build): the
# same seeded run in 1 and 2 processes on loopback (mpirun as root needs its flag; CI is root).
if [ $# -eq 0 ]; then
  cargo clippy -p avatar-neural --features mpi --all-targets --locked -- -D warnings
  cargo test -p avatar-neural --features mpi --locked --test meta_train_collective
fi

# The .deb (packaging/README.md): the binary the tests just built, packaged from
# [package.metadata.deb], installed with dpkg -i, run from /usr/bin (--version, a headless
# body) and removed again; a few seconds. Never replaces an installed avatar-studio and never
# needs root (both fall back to checking the package unpacked in a scratch folder).
if [ $# -eq 0 ]; then
  packaging/build-deb.sh --binary "$CARGO_TARGET_DIR/debug/avatar-studio"
else
  echo "the .deb check runs only with the whole suite (scripts/test.sh without arguments)"
fi
