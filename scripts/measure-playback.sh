#!/usr/bin/env bash
# The studio's playback rate in a real window (docs/studio.md, "Numbers"):
# starts the studio under Xvfb (an X server of SIZE, 1280 x 800 by default: the window fills it), lets
# `--measure-playback` press Play on the demo, bake the clip and count the frames drawn for 5 s,
# RUNS times, each with the load average beside it. Renders with whatever Vulkan driver there
# is (lavapipe on a machine without a GPU). Needs xvfb (`apt-get install xvfb`).
#   scripts/measure-playback.sh [RUNS] [WIDTHxHEIGHT] [-- extra studio flags, e.g. --quick-fit]
# BIN picks the binary (default: $CARGO_TARGET_DIR/debug/avatar-studio if built, else the one
# on PATH).
set -euo pipefail
cd "$(dirname "$0")/.."

runs="${1:-3}"
size="${2:-1280x800}"
shift $(( $# < 2 ? $# : 2 ))
[ "${1:-}" = "--" ] && shift
target="${CARGO_TARGET_DIR:-$HOME/.cache/avatar-studio/target}"
bin="${BIN:-}"
if [ -z "$bin" ]; then
  if [ -x "$target/debug/avatar-studio" ]; then bin="$target/debug/avatar-studio"; else bin="$(command -v avatar-studio)"; fi
fi
command -v xvfb-run >/dev/null || { echo "error: xvfb-run is missing (apt-get install xvfb)" >&2; exit 1; }

export WGPU_BACKEND="${WGPU_BACKEND:-vulkan}"
export XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp/avatar-studio-runtime}"
mkdir -p "$XDG_RUNTIME_DIR" && chmod 0700 "$XDG_RUNTIME_DIR"
# A fresh settings folder each run: eframe remembers the window's size and would reuse it.
data=$(mktemp -d)
trap 'rm -rf "$data"' EXIT

echo "binary: $bin ($("$bin" --version)), screen $size, $(nproc) cores"
for i in $(seq "$runs"); do
  rm -rf "${data:?}"/*
  before=$(cut -d' ' -f1 /proc/loadavg)
  line=$(XDG_DATA_HOME="$data" xvfb-run -a -s "-screen 0 ${size}x24" "$bin" --measure-playback "$@" 2>&1 | grep '^timing: playback' || true)
  after=$(cut -d' ' -f1 /proc/loadavg)
  echo "run $i (load average $before -> $after): ${line:-no measurement (the studio failed; run it by hand)}"
done
