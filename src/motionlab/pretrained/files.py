"""Reading released checkpoint folders safely: the error class, ``torch.load(weights_only=True)``, the config
files (MoMask's ``opt.txt``, DisCoRD's YAML), the ``meta`` normalisation and the strict state-dict check.

Nothing here runs code from a file: checkpoints go through torch's safe unpickler (tensors and plain Python
values only), YAML through ``yaml.SafeLoader``, ``.npy`` through ``np.load(allow_pickle=False)``.
"""

from __future__ import annotations

import collections
import functools
import math
import pickle
import re
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch

from ..representation import Normalizer

SHOW = 5  # how many keys an error message lists per kind of problem

# Types a released checkpoint may hold besides tensors and plain values, allowed by name and nothing else:
# MoMask's ``.tar`` carries its MultiStepLR state, whose ``milestones`` is a ``collections.Counter``.
SAFE_GLOBALS: tuple[type, ...] = (collections.Counter,)


class CheckpointError(ValueError):
    """A checkpoint file or folder that does not hold what its layout promises (names the file and the problem)."""


class UnsupportedSettingError(CheckpointError):
    """A released config uses a setting motionlab's modules do not implement (names the setting and its value)."""


def refuse(source: str, setting: str, value: Any, supported: str) -> UnsupportedSettingError:
    """The error for one unsupported setting: ``source: setting=value is not supported (motionlab implements ...)``."""
    return UnsupportedSettingError(f"{source}: {setting}={value!r} is not supported (motionlab implements {supported})")


# ----------------------------------------------------------------------------- files


def require_files(folder: Path, names: Iterable[str], layout: str) -> dict[str, Path]:
    """``{name: folder/name}``; raises ``FileNotFoundError`` naming every missing file and the expected layout."""
    paths = {name: folder / name for name in names}
    missing = [name for name, path in paths.items() if not path.is_file()]
    if missing:
        raise FileNotFoundError(
            f"{folder} is not a complete {layout} folder: missing {', '.join(missing)}\n  expected: {', '.join(paths)}"
        )
    return paths


def load_torch_file(path: Path) -> Any:
    """``torch.load(path, map_location="cpu", weights_only=True)`` with :data:`SAFE_GLOBALS` allowed.

    A file the safe unpickler refuses, or that is damaged or truncated, raises :class:`CheckpointError`
    naming the file (never a retry with ``weights_only=False``).
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"checkpoint not found: {path}")
    try:
        with torch.serialization.safe_globals(list(SAFE_GLOBALS)):
            return torch.load(path, map_location="cpu", weights_only=True)
    except pickle.UnpicklingError as err:
        found = re.search(r"Unsupported global: GLOBAL (\S+)", str(err))
        if found:
            raise CheckpointError(
                f"{path}: torch.load(weights_only=True) refused it: it holds a {found.group(1)} object, not only "
                "tensors and plain values; motionlab does not unpickle arbitrary objects"
            ) from err
        detail = re.search(r"WeightsUnpickler error:\s*(.*?)\s*(?:Check the documentation|$)", str(err), re.S)
        raise CheckpointError(
            f"{path}: not a readable torch checkpoint (damaged or truncated?): the safe unpickler stopped at "
            f"{detail.group(1).strip() if detail else _first_line(err)!r}"
        ) from err
    except Exception as err:  # zip, EOF, key and decode errors of a damaged file
        raise CheckpointError(
            f"{path}: not a readable torch checkpoint (damaged or truncated?): {type(err).__name__}: {_first_line(err)}"
        ) from err


def state_dict_in(checkpoint: Any, path: Path, keys: tuple[str, ...], layout: str) -> dict[str, Any]:
    """The state dict stored under the first of ``keys`` present in a checkpoint dict (``()``: the dict itself)."""
    if not isinstance(checkpoint, Mapping):
        raise CheckpointError(f"{path}: expected a dict ({layout}), found a {type(checkpoint).__name__}")
    if keys:
        key = next((k for k in keys if k in checkpoint), None)
        if key is None:
            raise CheckpointError(
                f"{path}: no state dict under {' or '.join(map(repr, keys))} ({layout}); "
                f"top-level keys: {_names(list(checkpoint))}"
            )
        checkpoint = checkpoint[key]
        if not isinstance(checkpoint, Mapping):
            raise CheckpointError(f"{path}: {key!r} holds a {type(checkpoint).__name__}, not a state dict")
    return dict(checkpoint)


def match_state_dict(
    found: Mapping[str, Any], expected: Mapping[str, tuple[int, ...]], path: Path, what: str, hint: str
):
    """Strict check of a state dict against ``expected`` key → shape: every key present, nothing else, same shapes.

    Raises one :class:`CheckpointError` listing the first missing, unexpected and mismatched keys, then ``hint``
    (what the folder should contain).
    """
    missing = [k for k in expected if k not in found]
    unexpected = [k for k in found if k not in expected]
    problems = []
    for key in expected:
        if key not in found:
            continue
        value = found[key]
        if not isinstance(value, torch.Tensor):
            problems.append(f"{key}: expected a tensor of shape {expected[key]}, found a {type(value).__name__}")
        elif tuple(value.shape) != tuple(expected[key]):
            problems.append(f"{key}: expected shape {tuple(expected[key])}, found {tuple(value.shape)}")
    if not (missing or unexpected or problems):
        return
    lines = [f"{path}: the state dict does not match {what}"]
    for label, items in (("missing keys", missing), ("unexpected keys", unexpected), ("shape mismatches", problems)):
        if items:
            more = f" (+{len(items) - SHOW} more)" if len(items) > SHOW else ""
            lines.append(f"  {label} ({len(items)}): " + "; ".join(items[:SHOW]) + more)
    lines.append(f"  {hint}")
    raise CheckpointError("\n".join(lines))


# ----------------------------------------------------------------------------- configs


def _parse_opt_value(value: str) -> Any:
    """MoMask's ``get_opt`` rules: True/False, ``d.d`` floats, digit strings as ints, anything else a string."""
    if value in ("True", "False"):
        return value == "True"
    unsigned = value.strip().lstrip("-").lstrip("+")
    if re.fullmatch(r"[0-9]+\.[0-9]+", unsigned):
        return float(value)
    if unsigned.isdigit():
        return int(value)
    return value  # 'None', lists like '[150000, 250000]' and '1e-05' stay strings, as in MoMask


def read_opt_txt(path: Path) -> dict[str, Any]:
    """Parse MoMask's ``opt.txt``: ``key: value`` lines between the Options and End separator lines."""
    options: dict[str, Any] = {}
    try:
        lines = Path(path).read_text(encoding="utf-8").splitlines()
    except (OSError, UnicodeDecodeError) as err:
        raise CheckpointError(f"{path}: cannot read the options file: {err}") from err
    for number, line in enumerate(lines, 1):
        text = line.strip()
        if not text or set(text) <= set("-") or text.strip("- ") in ("Options", "End"):
            continue  # separator lines and blanks
        key, sep, value = line.rstrip("\r").partition(": ")
        if not sep or not key.strip():
            raise CheckpointError(f"{path}:{number}: expected 'key: value', found {line!r}")
        options[key.strip()] = _parse_opt_value(value)
    if not options:
        raise CheckpointError(f"{path}: no options found (expected 'key: value' lines)")
    return options


@functools.cache
def _yaml_loader() -> type:
    """``yaml.SafeLoader`` that also reads ``5e-4`` as a float, as OmegaConf (DisCoRD's reader) does."""
    import yaml

    class Loader(yaml.SafeLoader):
        pass

    exponent = re.compile(r"^[-+]?(?:[0-9][0-9_]*(?:\.[0-9_]*)?|\.[0-9_]+)[eE][-+]?[0-9]+$")
    Loader.add_implicit_resolver("tag:yaml.org,2002:float", exponent, list("-+0123456789."))
    return Loader


def read_yaml(path: Path) -> dict[str, Any]:
    """A YAML mapping read with the safe loader; errors name the file."""
    import yaml

    try:
        data = yaml.load(Path(path).read_text(encoding="utf-8"), Loader=_yaml_loader())
    except (OSError, UnicodeDecodeError, yaml.YAMLError) as err:
        raise CheckpointError(f"{path}: cannot read the YAML config: {err}") from err
    if not isinstance(data, dict):
        raise CheckpointError(f"{path}: expected a YAML mapping, found {type(data).__name__}")
    return data


def load_normalizer(mean_path: Path, std_path: Path, feature_dim: int | None = None) -> Normalizer:
    """The released ``mean.npy`` / ``std.npy`` as a :class:`~motionlab.representation.Normalizer`."""
    arrays = []
    for path in (mean_path, std_path):
        try:
            arrays.append(np.load(path, allow_pickle=False))
        except (OSError, ValueError, EOFError) as err:
            raise CheckpointError(f"{path}: not a readable .npy array: {err}") from err
    try:
        normalizer = Normalizer(*arrays)
    except ValueError as err:
        raise CheckpointError(f"{mean_path.parent}: bad mean/std: {err}") from err
    if feature_dim is not None and normalizer.dim != feature_dim:
        raise CheckpointError(
            f"{mean_path.parent}: mean/std have {normalizer.dim} features but the model has {feature_dim}"
        )
    return normalizer


# ----------------------------------------------------------------------------- helpers


def as_int(value: Any, source: str, key: str) -> int:
    """An integer setting (``bool`` and non-integral floats refused)."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not float(value).is_integer():
        raise CheckpointError(f"{source}: {key} must be an integer, found {value!r}")
    return int(value)


def as_float(value: Any, source: str, key: str) -> float:
    """A real-valued setting; MoMask's ``opt.txt`` leaves ``1e-05`` a string, so strings are parsed too."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = math.nan
    if isinstance(value, bool) or not math.isfinite(number):
        raise CheckpointError(f"{source}: {key} must be a number, found {value!r}")
    return number


def _names(items: list[Any]) -> str:
    shown = ", ".join(map(repr, items[:SHOW]))
    return shown + (f" (+{len(items) - SHOW} more)" if len(items) > SHOW else "") if items else "none"


def _first_line(err: BaseException) -> str:
    lines = [line.strip() for line in str(err).splitlines() if line.strip()]
    return lines[0][:300] if lines else type(err).__name__
