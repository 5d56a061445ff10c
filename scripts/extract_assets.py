#!/usr/bin/env python3
"""Extracts the Sweet Home 3D furniture models the scenes use into the asset cache.

Source: Debian's sweethome3d-furniture package, and only its CC-0 (public-domain) archive,
/usr/share/sweethome3d/furniture/BlendSwap-CC-0.sh3f (a zip; each model is a folder
blendswap-cc-0/<model>/ holding its OBJ, MTL, textures and Blend Swap licence file).

Destination: $ARENA_ASSET_DIR/sweethome3d/<model>/ (default <repo>/cache/assets, never committed),
which scene files name as "assets:sweethome3d/<model>/<file>".

  python3 scripts/extract_assets.py              # every model a scene in scenes/ names
  python3 scripts/extract_assets.py sofa2 lamp2  # just these

Idempotent: a model whose folder exists is left alone. Atomic: a model is extracted into a
temporary folder beside its destination and renamed into place only when complete, so an
interrupted run leaves either nothing or the whole model (temporaries of killed runs are removed
on the next run). Errors name the archive, the model or the member and exit with status 1.

Environment: ARENA_SH3F_ARCHIVE overrides the archive path, ARENA_ASSET_DIR the cache.
"""
import os
import re
import shutil
import sys
import zipfile
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DEFAULT_ARCHIVE = "/usr/share/sweethome3d/furniture/BlendSwap-CC-0.sh3f"
PREFIX = "blendswap-cc-0/"  # the folder of the CC-0 archive that holds one folder per model
SUBDIR = "sweethome3d"  # under the asset cache
TEMP_MARK = ".partial-"  # temporaries: <cache>/sweethome3d/.partial-<model>-<pid>
MODEL_NAME = re.compile(r"^[A-Za-z0-9_]+$")


class ExtractError(Exception):
    pass


def models_named_by_scenes(scenes_dir):
    """Model names in "assets:sweethome3d/<model>/..." references of the scene files."""
    pattern = re.compile(r"assets:" + SUBDIR + r"/([^/\"]+)/")
    found = set()
    for scene in sorted(Path(scenes_dir).glob("*.json")):
        found.update(pattern.findall(scene.read_text(encoding="utf-8")))
    return sorted(found)


def remove_stale_temporaries(root):
    if not root.is_dir():
        return
    for entry in root.iterdir():
        if entry.name.startswith(TEMP_MARK):
            shutil.rmtree(entry, ignore_errors=True)


def extract_model(archive, zf, model, root):
    """Extracts blendswap-cc-0/<model>/ into root/<model>, atomically. Returns True if it did."""
    final = root / model
    if final.is_dir():
        return False
    members = [
        info for info in zf.infolist()
        if info.filename.startswith(PREFIX + model + "/") and not info.is_dir()
    ]
    if not members:
        raise ExtractError(f"{archive}: no model '{model}' (no files under {PREFIX}{model}/)")
    root.mkdir(parents=True, exist_ok=True)
    temp = root / f"{TEMP_MARK}{model}-{os.getpid()}"
    try:
        temp.mkdir()
        for info in members:
            relative = info.filename[len(PREFIX + model + "/"):]
            parts = Path(relative).parts
            # A member's path stays inside the model's folder: no absolute paths, no "..".
            if not parts or Path(relative).is_absolute() or ".." in parts:
                raise ExtractError(f"{archive}: member '{info.filename}' escapes the model folder")
            target = temp.joinpath(*parts)
            target.parent.mkdir(parents=True, exist_ok=True)
            with zf.open(info) as src, open(target, "wb") as dst:
                shutil.copyfileobj(src, dst)
        os.rename(temp, final)
    except (zipfile.BadZipFile, OSError, EOFError) as e:
        shutil.rmtree(temp, ignore_errors=True)
        raise ExtractError(f"{archive}: model '{model}' not extracted ({e}); no partial folder left in {root}")
    except BaseException:
        shutil.rmtree(temp, ignore_errors=True)
        raise
    return True


def main(argv):
    archive = os.environ.get("ARENA_SH3F_ARCHIVE", DEFAULT_ARCHIVE)
    root = Path(os.environ.get("ARENA_ASSET_DIR", REPO / "cache" / "assets")) / SUBDIR
    models = argv[1:] or models_named_by_scenes(REPO / "scenes")
    for model in models:
        if not MODEL_NAME.match(model):
            raise ExtractError(f"model name '{model}': expected letters, digits and underscores only")
    if all((root / m).is_dir() for m in models):
        return 0  # everything is in place: the archive is not needed
    if not os.path.isfile(archive):
        raise ExtractError(
            f"archive not found: {archive} (the CC-0 furniture of Debian's sweethome3d-furniture "
            f"package: apt-get install sweethome3d-furniture, or set ARENA_SH3F_ARCHIVE)")
    remove_stale_temporaries(root)
    try:
        zf = zipfile.ZipFile(archive)
    except (zipfile.BadZipFile, OSError) as e:
        raise ExtractError(f"{archive}: not a readable zip archive ({e})")
    with zf:
        done = [m for m in models if extract_model(archive, zf, m, root)]
    if done:
        print(f"extract_assets: {', '.join(done)} -> {root}")
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main(sys.argv))
    except ExtractError as e:
        print(f"extract_assets: error: {e}", file=sys.stderr)
        sys.exit(1)
    except (OSError, zipfile.BadZipFile) as e:
        print(f"extract_assets: error: {e}", file=sys.stderr)
        sys.exit(1)
