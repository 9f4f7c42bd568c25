"""Where the built-in configuration folders are, and how a config is chosen by name.

Configs live in `configs/<kind>/<name>.yaml` (animals, controllers, scenes). A run names them
by bare name (`dog`) or by path (`./my_dog.yaml`). The folder is the repository's `configs/`
in a checkout, the copy packaged as `quadpipe/configs/` in a wheel, or `$QUADPIPE_CONFIGS`.
"""

from __future__ import annotations

import os
from pathlib import Path

from quadpipe.core.errors import QuadpipeError, did_you_mean
from quadpipe.core.textfiles import missing_file

CONFIG_SUFFIX = ".yaml"


def config_root() -> Path:
    """The folder holding `animals/`, `controllers/`, `scenes/`, `skeletons/`, `limits/`."""
    if env := os.environ.get("QUADPIPE_CONFIGS"):
        return Path(env)
    packaged = Path(__file__).resolve().parents[1] / "configs"
    return packaged if packaged.is_dir() else Path(__file__).resolve().parents[2] / "configs"


def available(kind: str) -> list[str]:
    """Names of the built-in configs of one kind (`animals`, `controllers`, `scenes`)."""
    folder = config_root() / kind
    return sorted(p.stem for p in folder.glob(f"*{CONFIG_SUFFIX}"))


def find_config(kind: str, name_or_path: str | Path) -> Path:
    """Resolve a config given by name (built-in) or by path.

    Raises:
        QuadpipeError: no such file or built-in name; the message lists the valid names.
    """
    text = str(name_or_path)
    candidate = Path(text)
    looks_like_path = candidate.suffix in (CONFIG_SUFFIX, ".yml") or os.sep in text
    if looks_like_path:
        if candidate.is_file():
            return candidate
        raise QuadpipeError([missing_file(candidate, kind[:-1], name=text, suffixes=(CONFIG_SUFFIX, ".yml"))])
    path = config_root() / kind / f"{text}{CONFIG_SUFFIX}"
    if path.is_file():
        return path
    raise QuadpipeError.single(
        f"unknown-{kind[:-1]}",
        f"there is no {kind[:-1]} named {text!r}",
        hint=did_you_mean(text, available(kind)) or f"no {kind} are installed in {config_root() / kind}",
    )
