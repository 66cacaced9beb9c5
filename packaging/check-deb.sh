#!/usr/bin/env bash
# Installs a built avatar-studio .deb and checks it: the installed files, `avatar-studio
# --version` and a headless `avatar-studio body` from /usr/bin; then removes it again.
#   packaging/check-deb.sh PATH/avatar-studio_VERSION_ARCH.deb
# Never replaces a package that is already installed, and never fails for lack of root:
# - avatar-studio already installed (a developer's machine), or a /usr/bin/avatar-studio from
#   elsewhere: the package is unpacked into a scratch folder (dpkg-deb -x) and checked there;
#   the installed one is left alone.
# - neither root nor password-less sudo: the same scratch check, with a note.
# - otherwise: dpkg -i (apt fetches missing dependencies), the checks, dpkg -r.
set -euo pipefail

deb="${1:?usage: packaging/check-deb.sh FILE.deb}"
[ -f "$deb" ] || { echo "error: $deb: no such package" >&2; exit 1; }
name=$(dpkg-deb -f "$deb" Package)
version=$(dpkg-deb -f "$deb" Version)
scratch=$(mktemp -d)
trap 'rm -rf "$scratch"' EXIT

# The checks, with the installed tree under $1 ("" = the system).
check() {
  local root="$1"
  for f in usr/bin/avatar-studio usr/share/applications/avatar-studio.desktop \
           usr/share/icons/hicolor/256x256/apps/avatar-studio.png usr/share/doc/avatar-studio/copyright; do
    [ -e "$root/$f" ] || { echo "error: the package did not install /$f" >&2; return 1; }
  done
  local v
  v=$("$root/usr/bin/avatar-studio" --version)
  [ "$v" = "avatar-studio ${version%-*}" ] || { echo "error: --version says '$v', the package is $version" >&2; return 1; }
  "$root/usr/bin/avatar-studio" body --out "$scratch/rest.obj" >/dev/null
  [ -s "$scratch/rest.obj" ] || { echo "error: avatar-studio body wrote nothing" >&2; return 1; }
  echo "$v, avatar-studio body: $(grep -c '^v ' "$scratch/rest.obj") vertices"
}

unpacked() {
  dpkg-deb -x "$deb" "$scratch/root"
  echo "checked $deb unpacked in a scratch folder ($1): $(check "$scratch/root")"
}

if dpkg-query -W -f='${Status}' "$name" 2>/dev/null | grep -q "ok installed"; then
  unpacked "$name $(dpkg-query -W -f='${Version}' "$name") is installed on this machine and was left alone"
  exit 0
fi
if [ -e /usr/bin/avatar-studio ]; then
  unpacked "/usr/bin/avatar-studio exists outside any package and was left alone"
  exit 0
fi
if [ "$(id -u)" = 0 ]; then SUDO=""
elif command -v sudo >/dev/null && sudo -n true 2>/dev/null; then SUDO="sudo -n"
else
  unpacked "not installed: neither root nor password-less sudo"
  exit 0
fi

log="$scratch/install.log"
remove() { $SUDO dpkg -r "$name" >>"$log" 2>&1 || true; }
if ! $SUDO env DEBIAN_FRONTEND=noninteractive dpkg -i "$deb" >"$log" 2>&1; then
  # Missing dependencies leave the package unpacked: apt fetches them and configures it (with
  # fresh package lists if the first try finds none).
  fix() { $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -f -y -qq --no-install-recommends >>"$log" 2>&1; }
  if ! fix && ! { $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq >>"$log" 2>&1 && fix; }; then
    tail -n 20 "$log"; remove
    echo "error: could not install $deb" >&2; exit 1
  fi
fi
trap 'remove; rm -rf "$scratch"' EXIT
[ "$(command -v avatar-studio)" = /usr/bin/avatar-studio ] || echo "note: avatar-studio on PATH is $(command -v avatar-studio), checking /usr/bin/avatar-studio"
echo "installed $deb with dpkg -i, checked from /usr/bin: $(check "")"
remove
trap 'rm -rf "$scratch"' EXIT
echo "removed $name again"
