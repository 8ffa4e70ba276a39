"""Build the core's wheel for one platform, and pack one platform's extension zip.

    python scripts/platforms/build.py wheel PLATFORM     # -> addon/wheels/<that platform's wheel>
    python scripts/platforms/build.py pack PLATFORM      # -> dist/miniskeleton-<version>-<platform>.zip
    python scripts/platforms/build.py index --dist DIR   # Blender's repository index over DIR's zips
    python scripts/platforms/build.py platforms|wheels|zips [PLATFORM ...]   # names, paths (for make)

PLATFORM is one of Blender's platform names in the manifest (linux-x64, windows-x64,
macos-arm64, macos-x64). `addon/blender_manifest.toml` is the one list of platforms and wheels;
`TARGETS` below says how each is built, and both are checked against each other on every call.

- linux-x64 is this machine: rustup's toolchain, linked by zig against glibc 2.28 (manylinux_2_28).
- windows-x64 and macos-* are cross-built with Debian's rustc-web (scripts/platforms/toolchain.sh
  installs it): its std is compiled for the target by cargo's `-Zbuild-std` (RUSTC_BOOTSTRAP
  unlocks the option on a stable compiler); mingw-w64 links Windows, zig links macOS without an
  Apple SDK. The release profile's panic strategy stays `unwind`, so a panic in the core is
  still a Python exception on every platform (release_tests/ checks each binary for it).

`pack` builds each zip with Blender's own builder (`blender_ext.py build --split-platforms`) from
a staged copy of addon/ whose manifest keeps that one platform and its wheel, so a zip carries
only its own wheel and one platform's zip can be made without the others' wheels.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import tomllib
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
ADDON = ROOT / "addon"
MANIFEST = ADDON / "blender_manifest.toml"
DIST = ROOT / "dist"
HOST = "linux-x64"


@dataclass(frozen=True)
class Target:
    rust: str  # Rust target triple
    wheel_tag: str  # the wheel's platform tag
    cross: bool  # built with Debian's rustc-web and -Zbuild-std
    zig: bool  # zig links it
    # rustc strips the symbols (--strip). For Apple targets rustc strips with rust-objcopy, which
    # Debian's rustc-web does not ship: there even the profile's implicit debuginfo strip is off.
    strip: bool = False
    env: dict[str, str] = field(default_factory=dict)


TARGETS = {
    "linux-x64": Target("x86_64-unknown-linux-gnu", "manylinux_2_28_x86_64", cross=False, zig=True),
    "windows-x64": Target(
        "x86_64-pc-windows-gnu", "win_amd64", cross=True, zig=False, strip=True,
        env={"CARGO_TARGET_X86_64_PC_WINDOWS_GNU_LINKER": "x86_64-w64-mingw32-gcc"},
    ),
    # macOS 11 is the first release on Apple Silicon, and Blender 4.2's own minimum.
    "macos-arm64": Target(
        "aarch64-apple-darwin", "macosx_11_0_arm64", cross=True, zig=True,
        env={"MACOSX_DEPLOYMENT_TARGET": "11.0", "CARGO_PROFILE_RELEASE_STRIP": "false"},
    ),
    "macos-x64": Target(
        "x86_64-apple-darwin", "macosx_11_0_x86_64", cross=True, zig=True,
        env={"MACOSX_DEPLOYMENT_TARGET": "11.0", "CARGO_PROFILE_RELEASE_STRIP": "false"},
    ),
}
# Debian's compiler for the cross builds (scripts/platforms/toolchain.sh pins its version).
CROSS_RUSTC = "/usr/bin/rustc"
CROSS_CARGO_DIR = "/usr/bin"


def manifest() -> dict:
    with MANIFEST.open("rb") as fh:
        return tomllib.load(fh)


def wheels_by_platform() -> dict[str, Path]:
    """Each manifest platform's wheel, checked against TARGETS (raises SystemExit on drift)."""
    data = manifest()
    platforms = data.get("platforms", [])
    wheels = {Path(w).name: ADDON / w for w in data.get("wheels", [])}
    out = {}
    for platform in platforms:
        if platform not in TARGETS:
            sys.exit(f"{MANIFEST}: platform {platform!r} has no build target in {__file__}")
        name = f"miniskeleton_core-{data['version']}-cp311-abi3-{TARGETS[platform].wheel_tag}.whl"
        if name not in wheels:
            sys.exit(f"{MANIFEST}: platform {platform!r} needs the wheel ./wheels/{name} in `wheels`")
        out[platform] = wheels.pop(name)
    if wheels:
        sys.exit(f"{MANIFEST}: wheels of no listed platform: {sorted(wheels)}")
    return out


def zip_path(platform: str, dist: Path = DIST) -> Path:
    """The zip Blender's builder names for ``platform`` (e.g. miniskeleton-0.1.0-windows_x64.zip)."""
    data = manifest()
    return dist / f"{data['id']}-{data['version']}-{platform.replace('-', '_')}.zip"


def run(cmd: list[str], env: dict[str, str] | None = None) -> None:
    print("+", " ".join(cmd), flush=True)
    subprocess.run(cmd, check=True, env=env)


def build_wheel(platform: str, python: str, native: bool = False) -> Path:
    """Build ``platform``'s wheel into addon/wheels/ (replacing it) and return its path.
    ``native``: on a machine of that platform, with its own toolchain (the release workflow's
    second build on Windows and macOS, compiled by MSVC and Apple's linker)."""
    wheel = wheels_by_platform()[platform]
    target = TARGETS[platform]
    venv_bin = str(Path(python).parent)
    env = dict(os.environ)
    maturin = shutil.which("maturin", path=venv_bin) or "maturin"
    cmd = [maturin, "build", "--release", "--quiet"]
    if native:
        env.update(target.env)
        cmd += ["--interpreter", python] + (["--zig"] if platform == HOST else [])
    elif target.cross:
        subprocess.run([str(ROOT / "scripts" / "platforms" / "toolchain.sh")], check=True)
        env.pop("RUSTUP_TOOLCHAIN", None)
        # Debian's cargo and rustc first, before rustup's proxies.
        env["PATH"] = os.pathsep.join([venv_bin, CROSS_CARGO_DIR, env.get("PATH", "")])
        env.update(RUSTC=CROSS_RUSTC, RUSTC_BOOTSTRAP="1", **target.env)
        # The profile's panic strategy (unwind) is kept; panic_abort is built only because
        # -Zbuild-std needs both runtimes' crates to resolve std.
        cmd += ["--target", target.rust, "-Z", "build-std=std,panic_abort"]
        cmd += (["--zig"] if target.zig else []) + (["--strip"] if target.strip else [])
    else:
        env["PATH"] = os.pathsep.join([venv_bin, env.get("PATH", "")])
        cmd += ["--target", target.rust, "--interpreter", python] + (["--zig"] if target.zig else [])
    with tempfile.TemporaryDirectory(prefix="miniskeleton-wheel-") as out:
        run(cmd + ["--out", out], env=env)
        built = list(Path(out).glob("*.whl"))
        if [w.name for w in built] != [wheel.name]:
            sys.exit(f"maturin built {[w.name for w in built]}, the manifest expects {wheel.name}")
        wheel.parent.mkdir(parents=True, exist_ok=True)
        shutil.move(built[0], wheel)
    return wheel


def blender_ext_cli(python: str) -> Path:
    """Blender's extension command line (blender_ext.py) inside the bpy wheel of ``python``."""
    code = "import importlib.util, pathlib; print(pathlib.Path(importlib.util.find_spec('bpy').origin).parent)"
    bpy_dir = Path(subprocess.run([python, "-c", code], check=True, capture_output=True, text=True)
                   .stdout.strip().splitlines()[-1])
    found = sorted(bpy_dir.glob("*/scripts/addons_core/bl_pkg/cli/blender_ext.py"))
    if not found:
        sys.exit(f"no blender_ext.py under {bpy_dir}")
    return found[-1]


def stage(platform: str, into: Path) -> None:
    """Copy addon/ into ``into`` with a manifest that keeps ``platform`` and its wheel only."""
    wheel = wheels_by_platform()[platform]
    if not wheel.exists():
        sys.exit(f"{wheel.relative_to(ROOT)} is missing: run `make {wheel.relative_to(ROOT)}`")
    shutil.copytree(ADDON, into, ignore=shutil.ignore_patterns("__pycache__", "*.pyc", "wheels"))
    (into / "wheels").mkdir()
    shutil.copy2(wheel, into / "wheels" / wheel.name)
    text = MANIFEST.read_text()
    text, n_platforms = re.subn(r"(?m)^platforms\s*=\s*\[[^\]]*\]", f'platforms = ["{platform}"]', text)
    text, n_wheels = re.subn(r"(?ms)^wheels\s*=\s*\[.*?\]", f'wheels = ["./wheels/{wheel.name}"]', text)
    if (n_platforms, n_wheels) != (1, 1):
        sys.exit(f"{MANIFEST}: expected one `platforms = [...]` and one `wheels = [...]`")
    (into / MANIFEST.name).write_text(text)


def pack(platform: str, python: str, dist: Path = DIST) -> Path:
    """Build ``platform``'s extension zip in ``dist`` with Blender's builder; returns its path."""
    out = zip_path(platform, dist)
    dist.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="miniskeleton-pack-") as tmp:
        src = Path(tmp) / "miniskeleton"
        stage(platform, src)
        staged_out = Path(tmp) / "dist"
        staged_out.mkdir()
        run([python, str(blender_ext_cli(python)), "build", "--source-dir", str(src),
             "--output-dir", str(staged_out), "--split-platforms"])
        built = list(staged_out.glob("*.zip"))
        if [z.name for z in built] != [out.name]:
            sys.exit(f"Blender's builder made {[z.name for z in built]}, expected {out.name}")
        shutil.move(built[0], out)
    return out


def index(dist: Path, python: str) -> Path:
    """Blender's extension repository index (``server-generate``, with its HTML page) over the
    zips in ``dist``: what the release workflow publishes; returns the index.json path."""
    run([python, str(blender_ext_cli(python)), "server-generate", "--repo-dir", str(dist), "--html"])
    return dist / "index.json"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("command", choices=["wheel", "pack", "index", "platforms", "wheels", "zips"])
    parser.add_argument("platforms", nargs="*")
    parser.add_argument("--python", default=sys.executable, help="the virtualenv's Python (maturin, bpy)")
    parser.add_argument("--native", action="store_true", help="wheel: build with this machine's own toolchain")
    parser.add_argument("--dist", type=Path, default=DIST, help="pack, index: the folder of the zips")
    args = parser.parse_args()
    known = wheels_by_platform()
    platforms = args.platforms or list(known)
    for p in platforms:
        if p not in known:
            sys.exit(f"unknown platform {p!r}; the manifest lists {list(known)}")
    if args.command == "platforms":
        print(" ".join(platforms))
    elif args.command == "wheels":
        print("\n".join(str(known[p].relative_to(ROOT)) for p in platforms))
    elif args.command == "zips":
        print("\n".join(str(zip_path(p).relative_to(ROOT)) for p in platforms))
    elif args.command == "index":
        index(args.dist.resolve(), args.python)
    elif args.command == "wheel":
        for p in platforms:
            build_wheel(p, args.python, native=args.native)
    else:
        for p in platforms:
            pack(p, args.python, args.dist.resolve())


if __name__ == "__main__":
    main()
