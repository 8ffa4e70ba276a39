"""Each platform's extension zip and the core inside it, as `make extension` leaves them in dist/.

Per platform: the zip Blender's builder named for it, holding the add-on and that platform's
wheel only; Blender's `extension validate` accepts it; the wheel is abi3 for CPython 3.11 and
later with that platform's tag; the binary is that platform's, links only what every machine of
it has (no MinGW runtime DLL on Windows, no libpython anywhere, glibc <= 2.28 on Linux, macOS
11 as the stated minimum), exports only the module's init function, and carries the unwinder
that turns a panic into a Python exception (the release profile's panic strategy is unwind).
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
import tomllib
import zipfile
from pathlib import Path

import build
import pytest

ROOT = build.ROOT
PLATFORMS = list(build.wheels_by_platform())
MODULE = "miniskeleton_core"
INIT = f"PyInit_{MODULE}"

# What a Windows 10+ machine has: the OS's own DLLs, the C runtime that ships with Windows, and
# python3.dll (the stable ABI's forwarder, so any CPython >= 3.11 loads it).
WINDOWS_DLLS = re.compile(r"(?i)^(kernel32|ntdll|bcryptprimitives|msvcrt|ucrtbase|ws2_32|userenv|advapi32"
                          r"|api-ms-win-[a-z0-9-]+|python3)\.dll$")
# libSystem (with libc, libm, libunwind, pthreads) and the iconv that every macOS ships.
MACOS_DYLIBS = {"/usr/lib/libSystem.B.dylib", "/usr/lib/libiconv.2.dylib", "/usr/lib/libcharset.1.dylib"}
LINUX_LIBS = {"libc.so.6", "libm.so.6", "libgcc_s.so.1", "libpthread.so.0", "libdl.so.2", "ld-linux-x86-64.so.2"}
MANYLINUX_GLIBC = (2, 28)
# With panic=abort rustc emits no landing pads; with unwind the core has tens of kilobytes.
LSDA_MIN = 8192


def _out(*cmd: str) -> str:
    return subprocess.run(cmd, check=True, capture_output=True, text=True).stdout


def _zip(platform: str) -> Path:
    path = build.zip_path(platform)
    assert path.exists(), f"{path.relative_to(ROOT)} is missing: `make extension` builds it"
    return path


@pytest.fixture(scope="module")
def unpacked(tmp_path_factory):
    """Each platform's zip unpacked, and the wheel inside it unpacked: {platform: (zip dir, wheel dir)}."""
    out = {}
    for platform in PLATFORMS:
        base = tmp_path_factory.mktemp(platform)
        with zipfile.ZipFile(_zip(platform)) as zf:
            zf.extractall(base / "zip")
        wheels = list((base / "zip" / "wheels").glob("*.whl"))
        assert len(wheels) == 1, f"{platform}: {wheels}"
        with zipfile.ZipFile(wheels[0]) as zf:
            zf.extractall(base / "wheel")
        out[platform] = (base / "zip", base / "wheel")
    return out


def _lsda_bytes(section_headers: str, name: str) -> int:
    """Size of the section ``name`` (a regex) in objdump's or llvm-objdump's section list."""
    found = re.search(rf"^\s*\d+\s+{name}\s+([0-9a-f]+)\s", section_headers, re.M)
    assert found, section_headers
    return int(found.group(1), 16)


def _binary(wheel_dir: Path) -> Path:
    found = [p for p in (wheel_dir / MODULE).iterdir() if p.suffix in (".so", ".pyd")]
    assert len(found) == 1, found
    return found[0]


# ---------------------------------------------------------------- the zips


def test_one_zip_per_manifest_platform_named_as_blender_names_them():
    assert PLATFORMS == ["linux-x64", "windows-x64", "macos-arm64", "macos-x64"]
    for platform in PLATFORMS:
        assert _zip(platform).name == f"miniskeleton-0.1.0-{platform.replace('-', '_')}.zip"


@pytest.mark.parametrize("platform", PLATFORMS)
def test_zip_holds_the_addon_and_only_its_platforms_wheel(platform, unpacked):
    zip_dir, _ = unpacked[platform]
    wheel = build.wheels_by_platform()[platform]
    with zipfile.ZipFile(_zip(platform)) as zf:
        names = set(zf.namelist())
    sources = {p.relative_to(build.ADDON).as_posix() for p in build.ADDON.rglob("*")
               if p.is_file() and p.suffix in (".py", ".toml") and "__pycache__" not in p.parts}
    assert names == sources | {f"wheels/{wheel.name}"}
    # The bundled wheel is the one `make` built for that platform, byte for byte.
    assert (zip_dir / "wheels" / wheel.name).read_bytes() == wheel.read_bytes()
    with (zip_dir / "blender_manifest.toml").open("rb") as fh:
        manifest = tomllib.load(fh)
    assert manifest["build"]["generated"] == {"platforms": [platform], "wheels": [f"./wheels/{wheel.name}"]}


@pytest.mark.parametrize("platform", PLATFORMS)
def test_blender_validates_the_zip(platform):
    python = str(ROOT / ".venv" / "bin" / "python")
    result = subprocess.run([python, str(build.blender_ext_cli(python)), "validate", str(_zip(platform))],
                            capture_output=True, text=True)
    assert result.returncode == 0, result.stdout + result.stderr
    assert "Success" in result.stdout, result.stdout


def test_the_zips_make_one_extension_repository(tmp_path):
    """What the release workflow publishes: Blender's `server-generate` index over every zip,
    one entry per platform, each naming its own archive."""
    for platform in PLATFORMS:
        shutil.copy2(_zip(platform), tmp_path)
    index = json.loads(build.index(tmp_path, str(ROOT / ".venv" / "bin" / "python")).read_text())
    entries = {tuple(e["platforms"]): e for e in index["data"]}
    assert sorted(entries) == sorted((p,) for p in PLATFORMS)
    for (platform,), entry in entries.items():
        assert entry["id"] == "miniskeleton"
        assert entry["archive_url"].endswith(_zip(platform).name)
        assert entry["archive_size"] == _zip(platform).stat().st_size
    assert (tmp_path / "index.html").exists()


# ---------------------------------------------------------------- the wheels


@pytest.mark.parametrize("platform", PLATFORMS)
def test_wheel_is_abi3_for_python_311_and_later_with_its_platform_tag(platform, unpacked):
    _, wheel_dir = unpacked[platform]
    tag = f"cp311-abi3-{build.TARGETS[platform].wheel_tag}"
    meta = next(wheel_dir.glob("*.dist-info"))
    wheel_file = (meta / "WHEEL").read_text()
    assert re.findall(r"(?m)^Tag: (.+)$", wheel_file) == [tag]
    assert "Root-Is-Purelib: false" in wheel_file
    assert "Requires-Python: >=3.11" in (meta / "METADATA").read_text()
    suffix = ".pyd" if platform.startswith("windows") else ".abi3.so"
    assert _binary(wheel_dir).name == MODULE + suffix


def test_windows_pyd_imports_only_windows_and_python3_dll(unpacked):
    pyd = _binary(unpacked["windows-x64"][1])
    dump = _out("x86_64-w64-mingw32-objdump", "-p", str(pyd))
    assert "file format pei-x86-64" in _out("x86_64-w64-mingw32-objdump", "-f", str(pyd))
    dlls = re.findall(r"DLL Name: (\S+)", dump)
    assert "python3.dll" in dlls  # the stable ABI, not python311.dll
    assert [d for d in dlls if not WINDOWS_DLLS.match(d)] == []
    exports = re.findall(r"^\s*\[\s*\d+\] (\S+)$", dump.split("[Ordinal/Name Pointer] Table")[1], re.M)
    assert exports == [INIT]
    # Unwinding (MinGW's SEH unwinder, linked in statically) raises with RaiseException and
    # unwinds frames with RtlUnwindEx: with panic=abort neither would be imported.
    imported = set(re.findall(r"^\s+[0-9a-f]+\s+\d+\s+(\w+)$", dump, re.M))
    assert {"RaiseException", "RtlUnwindEx"} <= imported


@pytest.mark.parametrize("platform,cpu", [("macos-arm64", "ARM64"), ("macos-x64", "X86_64")])
def test_macos_so_is_its_cpu_links_no_libpython_and_states_macos_11(platform, cpu, unpacked):
    so = str(_binary(unpacked[platform][1]))
    header = _out("llvm-objdump-19", "--macho", "--private-header", so)
    assert re.search(rf"MH_MAGIC_64\s+{cpu}\s+\w+\s+\w+\s+DYLIB\s", header), header
    commands = _out("llvm-objdump-19", "--macho", "--private-headers", so)
    dylibs = set(re.findall(r"cmd LC_LOAD_DYLIB\n.*\n\s+name (\S+)", commands))
    assert dylibs and dylibs <= MACOS_DYLIBS, dylibs
    version = re.search(r"cmd LC_BUILD_VERSION\n.*\n\s+platform (\w+)\n\s+sdk \S+\n\s+minos (\S+)", commands)
    assert version and version.groups() == ("macos", "11.0"), commands
    # Apple Silicon runs only signed code: zig signs it ad hoc.
    assert ("cmd LC_CODE_SIGNATURE" in commands) == (cpu == "ARM64")
    # Python's own symbols are found in the process that loads the module (flat lookup), so no
    # libpython is linked and any CPython >= 3.11 serves.
    binds = _out("llvm-objdump-19", "--macho", "--bind", "--lazy-bind", so)
    python_binds = re.findall(r"(\S+)\s+(_Py\w+)$", binds, re.M)
    assert python_binds and {how for how, _ in python_binds} == {"flat-namespace"}
    # Landing pads (the LSDA table) exist, and the unwinder that runs them is libSystem's.
    sections = _out("llvm-objdump-19", "--section-headers", so)
    assert _lsda_bytes(sections, r"__gcc_except_tab") > LSDA_MIN
    undefined = set(_out("llvm-nm-19", "--undefined-only", "--just-symbol-name", so).split())
    assert "__Unwind_RaiseException" in undefined
    # zig's linker ignores rustc's exported-symbols list, so the Rust symbols stay visible (they
    # are bound two-level and harmless); of Python's C names only the module's init is defined.
    exported = _out("llvm-nm-19", "--extern-only", "--defined-only", "--just-symbol-name", so).split()
    assert "_" + INIT in exported
    assert [s for s in exported if s.startswith("_Py")] == ["_" + INIT]


def test_linux_so_is_manylinux_2_28_links_no_libpython_and_unwinds(unpacked):
    so = str(_binary(unpacked["linux-x64"][1]))
    needed = set(re.findall(r"NEEDED\s+(\S+)", _out("objdump", "-p", so)))
    assert needed and needed <= LINUX_LIBS, needed
    symbols = _out("objdump", "-T", so)
    glibc = {tuple(map(int, v.split("."))) for v in re.findall(r"GLIBC_(\d+(?:\.\d+)+)", symbols)}
    assert max(glibc) <= MANYLINUX_GLIBC
    # Landing pads (the LSDA table) exist; zig links LLVM's libunwind into the module.
    assert _lsda_bytes(_out("objdump", "-h", so), r"\.gcc_except_table") > LSDA_MIN
    assert b"libunwind:" in Path(so).read_bytes()
    exported = {line.split()[-1] for line in symbols.splitlines() if " .text" in line and " g " in line}
    assert exported == {INIT}


# ---------------------------------------------------------------- the build's panic strategy


def test_release_profile_unwinds_on_every_target():
    """Nothing sets panic=abort (profile, RUSTFLAGS in a cargo config), and each target's
    default strategy, as the compiler that builds it reports, is unwind."""
    with (ROOT / "Cargo.toml").open("rb") as fh:
        profiles = tomllib.load(fh).get("profile", {})
    assert profiles.get("release", {}).get("panic", "unwind") == "unwind"
    for config in (ROOT / ".cargo").glob("config*"):
        assert "panic" not in config.read_text(), config
    for platform in PLATFORMS:
        target = build.TARGETS[platform]
        rustc = build.CROSS_RUSTC if target.cross else "rustc"
        cfg = _out(rustc, "--print", "cfg", "--target", target.rust)
        assert 'panic="unwind"' in cfg, (platform, cfg)
