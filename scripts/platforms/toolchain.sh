#!/usr/bin/env bash
# The cross toolchain that builds the Windows and macOS wheels on a Debian bookworm x86_64 host:
# Debian's rustc-web with its std source (built by cargo's -Zbuild-std), mingw-w64 to link
# Windows, LLVM's objdump to read Mach-O. zig (PyPI's ziglang, in the virtualenv) links macOS.
#
# Installs the pinned packages when one is missing or at another version, then checks them.
# A Debian security update that moves rust-web away from the pin makes this fail with a message
# naming the new version: update RUST_WEB below (and the journal) on purpose, never silently.
set -euo pipefail

RUST_WEB="1.96.0+dfsg1-1~deb12u2"
MINGW_GCC="12.2.0-14+25.2"
MINGW_BINUTILS="2.40-2+10.4"
LLVM="1:19.1.7-3~deb12u1"

want=(
  "rustc-web=$RUST_WEB" "cargo-web=$RUST_WEB" "rust-web-src=$RUST_WEB" "libstd-rust-web-dev=$RUST_WEB"
  "gcc-mingw-w64-x86-64=$MINGW_GCC" "binutils-mingw-w64-x86-64=$MINGW_BINUTILS" "llvm-19=$LLVM"
)

installed() {  # package=version -> 0 when that version is installed
  local pkg="${1%%=*}" ver="${1#*=}"
  [ "$(dpkg-query -W -f='${Status} ${Version}' "$pkg" 2>/dev/null)" = "install ok installed $ver" ]
}

missing=()
for p in "${want[@]}"; do installed "$p" || missing+=("$p"); done

if [ ${#missing[@]} -gt 0 ]; then
  sudo=""
  [ "$(id -u)" = 0 ] || sudo="sudo"
  echo "cross toolchain: installing ${missing[*]}" >&2
  $sudo apt-get update -qq
  for p in "${missing[@]}"; do
    pkg="${p%%=*}" ver="${p#*=}"
    have=$(apt-cache policy "$pkg" | awk '/Candidate:/ {print $2}')
    if ! apt-cache madison "$pkg" | awk '{print $3}' | grep -qxF "$ver"; then
      echo "cross toolchain: $pkg $ver is no longer in Debian's archive (candidate: $have)." >&2
      echo "  Update the pin in scripts/platforms/toolchain.sh after checking the new version builds." >&2
      exit 1
    fi
  done
  DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}" >/dev/null
fi

for p in "${want[@]}"; do
  installed "$p" || { echo "cross toolchain: $p did not install" >&2; exit 1; }
done
# -Zbuild-std compiles the std source that matches the compiler exactly.
test -f /usr/lib/rustlib/src/rust/library/std/Cargo.toml || {
  echo "cross toolchain: rust-web-src's std source is missing at /usr/lib/rustlib/src/rust" >&2; exit 1; }
/usr/bin/rustc --version | grep -q "^rustc 1.96.0" || {
  echo "cross toolchain: /usr/bin/rustc is $(/usr/bin/rustc --version), not 1.96.0" >&2; exit 1; }
