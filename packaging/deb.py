#!/usr/bin/env python3
"""Build the .deb from a binary that is already built (any profile), with dpkg-deb.

The package is described once, in app/Cargo.toml's [package.metadata.deb] (the table
cargo-deb reads for the release package): the same files, modes, control fields and
dependencies ($auto from dpkg-shlibdeps, as cargo-deb does). The asset
"target/release/avatar-studio" is the binary given here. CI (scripts/test.sh) packages the
test build's binary this way in seconds, where cargo-deb would need its own release build
(packaging/README.md).

    packaging/deb.py --binary $CARGO_TARGET_DIR/debug/avatar-studio --out DIR

prints the path of the .deb it wrote. Python 3.11 (tomllib), dpkg-deb; strip and
dpkg-shlibdeps (binutils, dpkg-dev) when present.
"""

import argparse
import hashlib
import os
import shutil
import subprocess
import sys
import tempfile
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
APP = ROOT / "app"
REVISION = "1"  # cargo-deb's default revision


def fail(msg: str) -> None:
    print(f"error: {msg}", file=sys.stderr)
    sys.exit(1)


def metadata() -> tuple[dict, dict]:
    """(the [package] table with the workspace's values filled in, [package.metadata.deb])."""
    app = tomllib.loads((APP / "Cargo.toml").read_text())
    workspace = tomllib.loads((ROOT / "Cargo.toml").read_text()).get("workspace", {}).get("package", {})
    package = {k: (workspace[k] if isinstance(v, dict) and v.get("workspace") else v) for k, v in app["package"].items()}
    return package, app["package"]["metadata"]["deb"]


def auto_depends(binary: Path) -> list[str]:
    """The shared libraries' packages, as cargo-deb's $auto (dpkg-shlibdeps); [] without it."""
    if not shutil.which("dpkg-shlibdeps"):
        print("note: dpkg-shlibdeps is missing (dpkg-dev): $auto left out of Depends", file=sys.stderr)
        return []
    with tempfile.TemporaryDirectory() as tmp:
        (Path(tmp) / "debian").mkdir()
        (Path(tmp) / "debian" / "control").write_text("Source: x\n\nPackage: x\nArchitecture: any\n")
        out = subprocess.run(["dpkg-shlibdeps", "-O", "--ignore-missing-info", "-e", str(binary)], cwd=tmp, capture_output=True, text=True)
    if out.returncode != 0:
        print(f"note: dpkg-shlibdeps failed, $auto left out: {out.stderr.strip()}", file=sys.stderr)
        return []
    line = next((l for l in out.stdout.splitlines() if l.startswith("shlibs:Depends=")), "shlibs:Depends=")
    return [d.strip() for d in line.split("=", 1)[1].split(",") if d.strip()]


def install(src: Path, dest: Path, mode: str) -> None:
    dest.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(src, dest)
    os.chmod(dest, int(mode, 8))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--binary", required=True, type=Path, help="the built avatar-studio (any profile)")
    ap.add_argument("--out", required=True, type=Path, help="folder for the .deb")
    ap.add_argument("--no-strip", action="store_true", help="keep the binary's debug information")
    ap.add_argument("--compress", default="gzip", choices=["gzip", "xz", "zstd", "none"], help="dpkg-deb's compression (gzip: fast)")
    args = ap.parse_args()
    if not args.binary.is_file():
        fail(f"{args.binary}: no such binary (build it first)")
    if not shutil.which("dpkg-deb"):
        fail("dpkg-deb is missing (not a Debian/Ubuntu system?)")
    package, deb = metadata()
    name = deb.get("name", package["name"])
    arch = subprocess.run(["dpkg", "--print-architecture"], capture_output=True, text=True, check=True).stdout.strip()
    version = f"{package['version']}-{REVISION}"

    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp) / "root"
        for src, dest, mode in deb["assets"]:
            source = args.binary if src.startswith("target/release/") else APP / src
            if src.startswith("target/release/") and Path(src).name != args.binary.name:
                fail(f"asset {src}: only the binary {args.binary.name} is given")
            target = root / dest / source.name if dest.endswith("/") else root / dest
            install(source, target, mode)
            if source == args.binary and not args.no_strip and shutil.which("strip"):
                subprocess.run(["strip", "--strip-unneeded", str(target)], check=True)
        license_src, skip = deb["license-file"]
        lines = (APP / license_src).read_text().splitlines(keepends=True)[int(skip):]
        copyright_file = root / "usr/share/doc" / name / "copyright"
        copyright_file.parent.mkdir(parents=True, exist_ok=True)
        copyright_file.write_text("".join(lines))
        os.chmod(copyright_file, 0o644)

        depends = set()
        for d in (x.strip() for x in deb.get("depends", "$auto").split(",")):
            depends |= set(auto_depends(args.binary)) if d == "$auto" else {d} if d else set()
        files = sorted(p for p in root.rglob("*") if p.is_file())
        installed_kib = sum((p.stat().st_size + 1023) // 1024 for p in files)
        description = [package["description"]] + [" " + (l if l.strip() else ".") for l in wrap(deb.get("extended-description", ""))]
        control = {
            "Package": name,
            "Version": version,
            "Architecture": arch,
            "Section": deb.get("section"),
            "Priority": deb.get("priority"),
            "Maintainer": deb["maintainer"],
            "Installed-Size": str(installed_kib),
            "Depends": ", ".join(sorted(depends)),
            "Recommends": deb.get("recommends"),
            "Description": "\n".join(description),
        }
        debian = root / "DEBIAN"
        debian.mkdir()
        (debian / "control").write_text("".join(f"{k}: {v}\n" for k, v in control.items() if v))
        (debian / "md5sums").write_text("".join(f"{hashlib.md5(p.read_bytes()).hexdigest()}  {p.relative_to(root)}\n" for p in files))
        for d in [root, *(p for p in root.rglob("*") if p.is_dir())]:
            os.chmod(d, 0o755)
        args.out.mkdir(parents=True, exist_ok=True)
        out = args.out / f"{name}_{version}_{arch}.deb"
        partial = out.with_suffix(".deb.partial")
        subprocess.run(["dpkg-deb", "--root-owner-group", f"-Z{args.compress}", "--build", str(root), str(partial)], check=True, stdout=subprocess.DEVNULL)
        partial.replace(out)
    print(out)


def wrap(text: str, width: int = 79) -> list[str]:
    """The extended description as control-file lines (words wrapped, as cargo-deb does)."""
    lines = []
    for paragraph in text.split("\n"):
        line = ""
        for word in paragraph.split():
            if line and len(line) + 1 + len(word) > width:
                lines.append(line)
                line = word
            else:
                line = f"{line} {word}" if line else word
        lines.append(line)
    return lines


if __name__ == "__main__":
    main()
