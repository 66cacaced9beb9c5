#!/usr/bin/env bash
# Builds the .deb (cargo-deb, release build: about 17 min on 2 cores), installs it with dpkg
# and checks the installed binary: `avatar-studio --version` and a headless `avatar-studio
# body`. Debian/Ubuntu, as root or with sudo. Not part of scripts/test.sh (the release build
# is too long for every CI run); run it before a release:
#   ./packaging/build-deb.sh            # the .deb lands in $CARGO_TARGET_DIR/debian/
set -euo pipefail
cd "$(dirname "$0")/.."

export CARGO_TARGET_DIR="${CARGO_TARGET_DIR:-$HOME/.cache/avatar-studio/target}"
SUDO=""; [ "$(id -u)" = 0 ] || SUDO="sudo"

# What the build needs (a C compiler for bzip2-sys, zstd-sys and psm; pkg-config).
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

# Install (apt resolves the dependencies the package names: Vulkan loader, lavapipe, X11 and
# Wayland client libraries).
$SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq --no-install-recommends "$deb"
test -x /usr/bin/avatar-studio
test -f /usr/share/applications/avatar-studio.desktop
test -f /usr/share/icons/hicolor/256x256/apps/avatar-studio.png
test -f /usr/share/doc/avatar-studio/copyright

avatar-studio --version
out=$(mktemp -d)
avatar-studio body --out "$out/rest.obj"
test -s "$out/rest.obj"
echo "installed and checked: $(avatar-studio --version), $(grep -c '^v ' "$out/rest.obj") body vertices"
rm -rf "$out"
