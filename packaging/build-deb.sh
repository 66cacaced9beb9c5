#!/usr/bin/env bash
# Builds the .deb from app/Cargo.toml's [package.metadata.deb] and checks it installed
# (packaging/check-deb.sh: dpkg -i, the installed files, `avatar-studio --version` and a
# headless `avatar-studio body` from /usr/bin, dpkg -r; a package already installed is left
# alone and the new one checked unpacked in a scratch folder instead). Debian/Ubuntu.
#   ./packaging/build-deb.sh                # release build with cargo-deb (about 17 min on 2
#                                           # cores); the .deb lands in $CARGO_TARGET_DIR/debian/
#   ./packaging/build-deb.sh --binary PATH  # package a binary already built, any profile
#                                           # (packaging/deb.py with dpkg-deb: seconds); CI
#                                           # (scripts/test.sh) packages the test build's binary
set -euo pipefail
cd "$(dirname "$0")/.."

export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/avatar-studio/target}"
SUDO=""; [ "$(id -u)" = 0 ] || SUDO="sudo"

if [ "${1:-}" = "--binary" ]; then
  binary="${2:?--binary needs the path of a built avatar-studio}"
  if ! command -v dpkg-deb >/dev/null; then
    echo "packaging skipped: dpkg-deb is missing (not a Debian/Ubuntu system)"; exit 0
  fi
  if ! python3 -c 'import tomllib' 2>/dev/null; then
    echo "packaging skipped: packaging/deb.py needs Python 3.11 or newer (tomllib)"; exit 0
  fi
  start=$(date +%s)
  deb=$(packaging/deb.py --binary "$binary" --out "$CARGO_TARGET_DIR/debian-test")
  echo "built $deb from $binary in $(( $(date +%s) - start )) s"
  packaging/check-deb.sh "$deb"
  exit 0
fi

# What the release build needs (a C compiler for bzip2-sys, zstd-sys and psm; pkg-config).
need=()
command -v cc >/dev/null || need+=(build-essential)
command -v pkg-config >/dev/null || need+=(pkg-config)
command -v dpkg-shlibdeps >/dev/null || need+=(dpkg-dev)  # $auto dependencies
if [ ${#need[@]} -gt 0 ]; then
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "${need[@]}"
fi
command -v cargo-deb >/dev/null || cargo install cargo-deb --locked

start=$(date +%s)
cargo deb -p avatar-studio --locked
deb=$(ls -t "$CARGO_TARGET_DIR"/debian/avatar-studio_*.deb | head -n 1)
echo "built $deb in $(( $(date +%s) - start )) s"
packaging/check-deb.sh "$deb"
