"""Builds the Blender extension zip: the add-on (blender/squish_blender) with the squish wheel.

    python blender/build.py                      # builds the wheel (release profile), then the zip
    python blender/build.py --wheel PATH.whl     # bundles a wheel built before (CI: the dev build)
    python blender/build.py --profile dev        # the wheel in the dev profile (faster to build)

Writes dist/squish_blender-VERSION-PLATFORM.zip (install it in Blender: Edit > Preferences >
Get Extensions > Install from Disk). The manifest's `wheels` and `platforms` are filled from the
wheel bundled: Blender installs that wheel into the extension's private site-packages.
"""

from __future__ import annotations

import argparse
import os
import re
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
ADDON = ROOT / "blender" / "squish_blender"

# Wheel platform tags and the Blender platform names of the manifest.
_PLATFORMS = {
    "manylinux": "linux-x64",
    "linux_x86_64": "linux-x64",
    "macosx": "macos-arm64",
    "win_amd64": "windows-x64",
}


def build_wheel(profile: str, out: Path) -> Path:
    env = dict(os.environ)
    if profile != "release":
        env["MATURIN_PEP517_ARGS"] = f"--profile {profile}"
    crate = ROOT / "crates" / "squish-py"
    subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-w", str(out), str(crate)], check=True, env=env)
    wheels = sorted(out.glob("squish-*.whl"))
    if not wheels:
        sys.exit(f"build.py: pip wrote no squish wheel into {out}")
    return wheels[-1]


def platform_of(wheel: Path) -> str:
    tag = wheel.stem.split("-")[-1]
    for prefix, platform in _PLATFORMS.items():
        if prefix in tag:
            if platform == "macos-arm64" and "x86_64" in tag:
                return "macos-x64"
            return platform
    sys.exit(f"build.py: no Blender platform for the wheel tag {tag!r}; add it to _PLATFORMS")


def manifest_with(wheel: Path, platform: str) -> str:
    text = (ADDON / "blender_manifest.toml").read_text()
    # The source manifest lists no wheel (it is built here): fill the list and add the platform.
    # Both keys go where the empty list is, before the manifest's tables ([permissions]).
    listed = f'wheels = [\n  "./wheels/{wheel.name}",\n]\nplatforms = ["{platform}"]'
    filled, count = re.subn(r"wheels = \[\s*\]", lambda _: listed, text)
    if count != 1:
        sys.exit("build.py: blender_manifest.toml must hold one empty `wheels = [ ]` list")
    return filled


def build_zip(wheel: Path, out: Path) -> Path:
    version = re.search(r'^version = "([^"]+)"', (ADDON / "blender_manifest.toml").read_text(), re.M).group(1)
    platform = platform_of(wheel)
    target = out / f"squish_blender-{version}-{platform}.zip"
    out.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as archive:
        for path in sorted(ADDON.rglob("*")):
            if path.is_dir() or "__pycache__" in path.parts or path.name == "blender_manifest.toml":
                continue
            archive.write(path, path.relative_to(ADDON).as_posix())
        archive.writestr("blender_manifest.toml", manifest_with(wheel, platform))
        archive.write(wheel, f"wheels/{wheel.name}")
    return target


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--wheel", type=Path, help="bundle this squish wheel instead of building one")
    parser.add_argument("--profile", default="release", help="cargo profile of the wheel built (release, dev)")
    parser.add_argument("--out", type=Path, default=ROOT / "dist", help="folder of the zip (default: dist/)")
    args = parser.parse_args()
    if args.wheel is not None:
        if not args.wheel.is_file():
            sys.exit(f"build.py: {args.wheel}: no such wheel; build one or leave --wheel out")
        wheel = args.wheel
        print(build_zip(wheel, args.out))
        return
    with tempfile.TemporaryDirectory() as scratch:
        wheel = build_wheel(args.profile, Path(scratch))
        kept = args.out / wheel.name
        args.out.mkdir(parents=True, exist_ok=True)
        shutil.copy2(wheel, kept)
        print(build_zip(kept, args.out))


if __name__ == "__main__":
    main()
