"""Checks on what `make extension` releases: every platform's zip and the wheel inside it.
No platform's binary can run here but Linux's; these read them (objdump, llvm-objdump), and the
release workflow imports each in Blender on its own platform (.github/workflows/release.yml)."""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts" / "platforms"))
