"""Which ``firmware.bin`` an ``rp2040:`` URL means, and where it is.

A ``buildhat`` Python package carries one release's image in ``buildhat/data/`` (``firmware.bin`` and
``version``, the release number ``version`` prints). ``rp2040:R7``, ``rp2040:1737564117`` or
``rp2040:latest`` take the installed package's image when it is that release, else one from
``?images=DIR``: a folder holding, at any depth, ``firmware.bin`` beside its ``version`` (unpacked
packages, e.g. ``DIR/0.9.0/buildhat/data/``), or wheels ``buildhat-*.whl`` (read without unpacking
them into the folder). ``rp2040:PATH`` runs the image at PATH (release: its ``version`` file
beside it, if any).
"""
from __future__ import annotations

import hashlib
import os
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, Optional

from ..harness.targets.base import TargetError
from .install import cache_root

__all__ = ["Image", "find_image", "images_in", "installed_image", "unpack_wheel"]


@dataclass(frozen=True)
class Image:
    path: Path
    release: Optional[int]         # the number in its version file (None: not known)


def _release_of(version_file: Path) -> Optional[int]:
    try:
        return int(version_file.read_text(encoding="ascii").split()[0])
    except (OSError, ValueError, IndexError):
        return None


def installed_image() -> Optional[Image]:
    """The image of the ``buildhat`` package installed beside this one, if any."""
    import importlib.util
    spec = importlib.util.find_spec("buildhat")
    if spec is None or not spec.submodule_search_locations:
        return None
    data = Path(list(spec.submodule_search_locations)[0]) / "data"
    image = data / "firmware.bin"
    return Image(image, _release_of(data / "version")) if image.is_file() else None


def unpack_wheel(wheel: Path) -> Optional[Image]:
    """A wheel's image, copied once into the cache (by the wheel's content), else None."""
    digest = hashlib.sha256(wheel.read_bytes()).hexdigest()[:16]
    where = cache_root() / "images" / digest
    image = where / "firmware.bin"
    if not image.is_file():
        try:
            with zipfile.ZipFile(wheel) as whl:
                names = set(whl.namelist())
                if "buildhat/data/firmware.bin" not in names:
                    return None
                where.mkdir(parents=True, exist_ok=True)
                for name in ("firmware.bin", "version"):
                    if f"buildhat/data/{name}" in names:
                        tmp = where / (name + ".part")
                        tmp.write_bytes(whl.read(f"buildhat/data/{name}"))
                        os.replace(tmp, where / name)
        except (OSError, zipfile.BadZipFile):
            return None
    return Image(image, _release_of(where / "version"))


def images_in(folder: Path) -> Iterator[Image]:
    """Every image in ``folder``: ``firmware.bin`` files with their ``version``, and wheels' images."""
    for here, _dirs, files in os.walk(folder):
        for name in sorted(files):
            path = Path(here) / name
            if name == "firmware.bin":
                yield Image(path, _release_of(path.with_name("version")))
            elif name.startswith("buildhat-") and name.endswith(".whl"):
                image = unpack_wheel(path)
                if image is not None:
                    yield image


def find_image(spec: str, images: Optional[str] = None) -> Image:
    """The image an ``rp2040:SPEC`` URL names; a TargetError in one line when there is none."""
    from ..protocol.profiles import get_profile
    path = Path(os.path.expanduser(spec))
    if spec and (path.is_file() or os.sep in spec or spec.endswith(".bin")):
        if not path.is_file():
            raise TargetError(f"rp2040: no firmware image at {path}")
        return Image(path.resolve(), _release_of(path.with_name("version")))
    try:
        wanted = get_profile(spec or None)
    except KeyError as exc:
        raise TargetError(f"rp2040: {exc.args[0]} (or give a firmware.bin file)") from None
    found = [installed_image()]
    if images:
        folder = Path(os.path.expanduser(images))
        if not folder.is_dir():
            raise TargetError(f"rp2040: ?images={images}: no such folder")
        found += list(images_in(folder))
    for image in found:
        if image is not None and image.release == wanted.number:
            return image
    where = f"in {images} or " if images else ""
    raise TargetError(f"rp2040: no firmware.bin of {wanted} {where}in an installed buildhat package; "
                      f"install the buildhat release that carries it, or name a folder of images with "
                      f"?images=DIR")
