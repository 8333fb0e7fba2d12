"""Bring your own mocap: a folder of BVH takes -> a dataset in the HumanML3D layout that the book trains on.

The steps, for every take ``FOLDER/<name>.bvh`` (in file-name order)::

    read_bvh --bvh_to_joints (rig: joint names, metres, up axis; 20 fps; optional crop)--> joints (T, 22, 3)
             --joints_to_features (retarget to t2m, floor, face +Z)--> new_joint_vecs/<id>.npy  (T-1, 263)
             --recover_from_ric--> new_joints/<id>.npy  (T-1, 22, 3)
    captions (CSV rows or the file name) --> texts/<id>.txt
    all clips --seeded 80/5/15 split--> train.txt val.txt test.txt all.txt;  train clips --> Mean.npy Std.npy

Captions. Without a CSV the file name is the caption: ``walk_forward_02.bvh`` -> "walk forward" (digits
dropped; ``_``, ``-`` and camelCase split words); a name without letters (CMU's ``131_01``) has no caption
and the take is skipped. A captions CSV has a header row with the columns

* ``take`` -- the file name, with or without ``.bvh``;
* ``caption`` -- one description; several rows for one take give it several captions;
* ``start``, ``end`` (optional columns, cells may be empty) -- a crop in frames at 20 fps, ``[start, end)``
  as in HumanML3D's ``index.csv``; rows of one take with different crops become different clips
  (``<take>_<start>-<end>``).

Any other column is an error (a misspelt ``caption`` column must not be dropped silently), and so is a
caption with ``#`` (the separator of the texts format) or without a word. With a CSV, a take without a row
is skipped and reported (never captioned by its file name behind the user's back); rows naming takes that
are not in the folder are reported as a note. Tokens are ``word/POS`` with the embedded generator's
lexicon (:func:`motionlab.data.embedded.captions.tag`); words outside it are tagged ``X`` ("other").

The rig. By default (``mapping="auto"``) every take's rig is detected from its joint names
(:func:`motionlab.io.bvh_import.detect_rig`: a BVH motionlab wrote, CMU's, t2m's), so a folder may mix them;
``"cmu"``/``"t2m"`` insist on one, and a dict or a ``.json`` joint map (t2m joint -> BVH joint) reads any rig.

Takes are skipped, with the reason in the report, when unreadable (truncated, NaN, malformed), when they
lack a joint of the rig (``mapping``), when the crop is outside the take, and when the clip falls outside
the length range HumanML3D's loaders keep: 40 to 199 feature frames at 20 fps (crop longer takes).

Resuming. ``DATASET/meta.json`` records every clip's source (file name, SHA-1, crop) and the rig; a re-run
into the same folder converts only what is new or changed and rewrites the texts, splits and statistics
(a pure function of the clips and ``seed``: an unchanged folder gives the same bytes). Clips whose take
has gone are removed. Any other non-empty ``DATASET`` is refused unless ``force``. A run that converts no take
leaves ``DATASET`` as it was.

Your files are safe. ``DATASET/.motionlab-manifest.json`` lists every file the command wrote there (a
dataset written before manifests existed: the files its ``meta.json`` records). Nothing else in the folder is
ever deleted or overwritten: ``force`` builds the new dataset beside ``DATASET`` and, once it is complete,
deletes the files the manifest lists and moves the new ones in, so a ``notes.txt`` of yours stays; a file of
yours where the dataset needs one of its own (say ``Mean.npy``) is an error before any work.
"""

from __future__ import annotations

import csv
import hashlib
import json
import os
import re
import shutil
import sys
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm.auto import tqdm

from ..io.bvh import read_bvh
from ..io.bvh_import import AUTO, BvhRig, bvh_to_joints, check_scale_up, resolve_rig
from ..io.common import write_text_atomic
from ..representation import T2M, Normalizer, joints_to_features, recover_from_ric
from .embedded.captions import tag
from .humanml3d import KINDS, Caption, format_caption_line
from .writing import CLIP_FOLDERS, clip_files, make_layout, stratified_split, write_clip, write_split_files

GENERATOR = "motionlab.data.from_bvh"
VERSION = 1  # bump when converted clips change, so resumed runs reconvert them
FPS = 20.0
CSV_COLUMNS = ("take", "caption", "start", "end")
UNKNOWN_POS = "X"  # spaCy's tag for "other": words the embedded lexicon does not know
MANIFEST = ".motionlab-manifest.json"  # the files this command wrote into a dataset folder
DATASET_FILES = ("meta.json", "Mean.npy", "Std.npy", "train.txt", "val.txt", "test.txt", "all.txt", MANIFEST)


def plural(n: int, word: str, many: str | None = None) -> str:
    """``"1 clip"``, ``"3 clips"`` (``many`` for irregular plurals)."""
    return f"{n} {word if n == 1 else many or word + 's'}"


@dataclass(frozen=True)
class ClipPlan:
    """One clip to make: a take (file name in the folder), an optional crop, its captions."""

    clip_id: str
    file: str
    start: int = 0
    end: int | None = None
    captions: tuple[str, ...] = ()

    @property
    def label(self) -> str:
        """How the report names it: the file name, plus the crop when there is one."""
        whole = (self.start, self.end) == (0, None)
        return self.file if whole else f"{self.file} [{self.start}, {'end' if self.end is None else self.end})"


@dataclass
class FromBvhReport:
    """What :func:`dataset_from_bvh` did; ``summary()`` is what the command line prints."""

    out: Path
    converted: dict[str, int] = field(default_factory=dict)  # clip id -> feature frames, converted this run
    reused: dict[str, int] = field(default_factory=dict)  # clip id -> feature frames, kept from an earlier run
    skipped: dict[str, str] = field(default_factory=dict)  # take file name (or clip id) -> why
    rigs: dict[str, str] = field(default_factory=dict)  # clip id -> the rig its take was read with
    splits: dict[str, int] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)
    seconds: float = 0.0
    convert_seconds: float = 0.0  # of which converting (reading, kinematics, features, writing)

    @property
    def clips(self) -> list[str]:
        return sorted({**self.converted, **self.reused})

    def summary(self) -> str:
        frames = sum(self.converted.values()) + sum(self.reused.values())
        per = f", {self.convert_seconds / len(self.converted):.2f} s each" if self.converted else ""
        lines = [
            f"wrote {self.out}: {plural(len(self.clips), 'clip')}, {plural(frames, 'frame')} at 20 fps "
            f"({frames / FPS:.1f} s of motion); {len(self.converted)} converted{per}, {len(self.reused)} reused; "
            + " / ".join(f"{name} {n}" for name, n in self.splits.items())
            + f"; {self.seconds:.1f} s"
        ]
        if self.rigs:
            counts = {rig: sum(r == rig for r in self.rigs.values()) for rig in sorted(set(self.rigs.values()))}
            lines.append("rigs: " + ", ".join(f"{rig} ({plural(n, 'clip')})" for rig, n in counts.items()))
        if self.skipped:
            lines.append(f"skipped {plural(len(self.skipped), 'take')}:")
            lines += [f"  {name}: {why}" for name, why in self.skipped.items()]
        lines += [f"note: {note}" for note in self.notes]
        return "\n".join(lines)


class _Skip(Exception):
    """A take that cannot become a clip; the message is the reason shown in the report."""


# --- captions ---------------------------------------------------------------------------------------------


def caption_from_name(stem: str) -> str | None:
    """``"walk_forward_02"`` / ``"WalkForward"`` -> ``"walk forward"``; None when the name has no letters."""
    words = re.findall(r"[a-z]+", re.sub(r"(?<=[a-z])(?=[A-Z])", " ", stem).lower())
    return " ".join(words) or None


def caption_to_line(text: str) -> str:
    """A HumanML3D texts line ``caption#tok/POS ...#0.0#0.0`` for a caption describing the whole clip."""
    return format_caption_line(Caption(text, tuple(tag(text, unknown=UNKNOWN_POS))))


def _clean_caption(text: str, where: str) -> str:
    text = " ".join(text.split())
    if "#" in text:
        raise ValueError(f"{where}: a caption must not contain '#' (the separator of HumanML3D's texts)")
    if not re.search(r"[a-zA-Z]", text):
        raise ValueError(f"{where}: the caption {text!r} has no words")
    return text


def _frame(cell: str | None, where: str, name: str) -> int | None:
    if cell is None or not cell.strip():
        return None
    try:
        value = int(cell)
    except ValueError:
        raise ValueError(f"{where}: {name} must be a whole number of frames at 20 fps, got {cell!r}") from None
    if value < 0:
        raise ValueError(f"{where}: {name} must not be negative, got {value}")
    return value


def read_captions_csv(path: str | os.PathLike) -> dict[str, dict[tuple[int, int | None], list[str]]]:
    """``take stem -> (start, end) -> captions`` from a captions CSV (format in the module docstring)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"captions file {path} does not exist")
    table: dict[str, dict[tuple[int, int | None], list[str]]] = {}
    with open(path, encoding="utf-8-sig", newline="") as fh:
        reader = csv.reader(fh)
        header = [h.strip().lower() for h in next(reader, [])]
        unknown = [h for h in header if h not in CSV_COLUMNS]
        if unknown or not {"take", "caption"} <= set(header) or len(set(header)) != len(header):
            raise ValueError(
                f"{path}: the header must name the columns take, caption and optionally start, end "
                f"(each once), got {', '.join(header) or 'an empty file'}"
            )
        for row in reader:
            if not any(cell.strip() for cell in row):
                continue
            where = f"{path} line {reader.line_num}"
            if len(row) != len(header):
                raise ValueError(f"{where}: {plural(len(row), 'cell')}, the header has {plural(len(header), 'column')}")
            cells = dict(zip(header, row))
            take = re.sub(r"\.bvh$", "", cells["take"].strip(), flags=re.IGNORECASE)
            if not take:
                raise ValueError(f"{where}: the take is empty")
            start = _frame(cells.get("start"), where, "start") or 0
            end = _frame(cells.get("end"), where, "end")
            if end is not None and end <= start:
                raise ValueError(f"{where}: end ({end}) must be greater than start ({start})")
            text = _clean_caption(cells["caption"], where)
            table.setdefault(take, {}).setdefault((start, end), []).append(text)
    if not table:
        raise ValueError(f"{path} has a header but no caption rows")
    return table


# --- planning ---------------------------------------------------------------------------------------------


def list_takes(folder: str | os.PathLike) -> list[Path]:
    """The ``.bvh`` files directly in ``folder`` (any case of the suffix), sorted by name."""
    folder = Path(folder)
    if not folder.is_dir():
        raise FileNotFoundError(
            f"the BVH folder {folder} does not exist" if not folder.exists() else f"{folder} is a file, not a folder"
        )
    takes = sorted(p for p in folder.iterdir() if p.is_file() and p.suffix.lower() == ".bvh")
    if not takes:
        raise ValueError(f"no .bvh files in {folder} (subfolders are not searched)")
    return takes


def _clip_id(stem: str, start: int = 0, end: int | None = None, cropped: bool = False) -> str:
    base = re.sub(r"[^A-Za-z0-9_.-]", "_", stem)
    return f"{base}_{start}-{'end' if end is None else end}" if cropped else base


def plan_clips(
    takes: list[Path], captions: Mapping[str, Mapping[tuple[int, int | None], list[str]]] | None
) -> tuple[list[ClipPlan], dict[str, str], list[str]]:
    """The clips to make, the takes skipped before reading them (name -> why), and notes."""
    plans: list[ClipPlan] = []
    skipped: dict[str, str] = {}
    owner: dict[str, str] = {}  # clip id -> file that claimed it
    for path in takes:
        if captions is None:
            text = caption_from_name(path.stem)
            if text is None:
                skipped[path.name] = "no caption: the file name has no words (give it rows in a captions CSV)"
                continue
            crops = {(0, None): [text]}
        elif path.stem not in captions:
            skipped[path.name] = "no row in the captions CSV"
            continue
        else:
            crops = captions[path.stem]
        for (start, end), texts in crops.items():
            cid = _clip_id(path.stem, start, end, cropped=(start, end) != (0, None))
            if cid in owner:
                skipped[path.name] = f"its clip id {cid!r} is already taken by {owner[cid]}"
                continue
            owner[cid] = path.name
            plans.append(ClipPlan(cid, path.name, start, end, tuple(texts)))
    notes = []
    if captions is not None:
        stems = {p.stem for p in takes}
        unused = sorted(t for t in captions if t not in stems)
        if unused:
            notes.append(
                f"the captions CSV names {plural(len(unused), 'take')} not in the folder: {', '.join(unused[:10])}"
                + (" ..." if len(unused) > 10 else "")
            )
    return plans, skipped, notes


# --- converting one clip ----------------------------------------------------------------------------------


@dataclass(frozen=True)
class _RigRequest:
    """The rig asked for: one rig for every take, or (``rig`` None) each take's detected from its joint names,
    with ``scale``/``up`` overriding the detected one's."""

    rig: BvhRig | None
    scale: float | None = None
    up: str | None = None

    def settings(self) -> dict:
        if self.rig is None:
            return {"rig": AUTO, "joint_map": None, "scale": self.scale, "up": self.up}
        rig = self.rig
        return {"rig": rig.name, "joint_map": dict(rig.joint_map), "scale": rig.scale, "up": rig.up}


def convert_clip(path: Path, plan: ClipPlan, rig: BvhRig | _RigRequest) -> tuple[np.ndarray, np.ndarray, str]:
    """Features ``(T-1, 263)`` and joints ``(T-1, 22, 3)`` (float32) of one clip, and the name of the rig it was
    read with; ``_Skip`` says why not. ``rig``: one rig, or a request whose rig is detected from the take's joint
    names (``_RigRequest.rig`` None)."""
    try:
        bvh = read_bvh(path)
    except (ValueError, OSError, UnicodeDecodeError) as err:
        raise _Skip(f"unreadable: {str(err).removeprefix(f'{path}: ')}") from None
    if isinstance(rig, _RigRequest):
        if rig.rig is not None:
            rig = rig.rig
        else:
            try:
                rig = resolve_rig(AUTO, rig.scale, rig.up, bvh, path.name)
            except ValueError as err:
                raise _Skip(f"wrong skeleton: {str(err).removeprefix(f'{path.name}: ')}") from None
    missing = [rig.joint_map[t] for t in T2M.joint_names if rig.joint_map[t] not in bvh.names]
    if missing:
        raise _Skip(
            f"wrong skeleton for the {rig.name!r} mapping: no joint {', '.join(missing[:6])}"
            + (f" (+{len(missing) - 6} more)" if len(missing) > 6 else "")
        )
    try:
        joints = bvh_to_joints(bvh, dict(rig.joint_map), rig.scale, rig.up, FPS, plan.start, plan.end)  # (T, 22, 3)
    except ValueError as err:
        raise _Skip(f"cannot convert: {err}") from None
    kind = KINDS["humanml3d"]
    rows = len(joints) - 1  # feature frames
    if rows < kind.min_length:
        raise _Skip(
            f"too short: {rows} frames at 20 fps ({rows / FPS:.1f} s); HumanML3D's loaders need at least "
            f"{kind.min_length}"
        )
    if rows >= kind.max_length:
        raise _Skip(
            f"too long: {rows} frames at 20 fps ({rows / FPS:.1f} s); HumanML3D's loaders keep fewer than "
            f"{kind.max_length}: crop it with start/end columns in a captions CSV"
        )
    try:
        features = joints_to_features(joints, T2M).astype(np.float32)  # (T-1, 263)
    except ValueError as err:
        raise _Skip(f"cannot compute features: {err}") from None
    if not np.isfinite(features).all():
        raise _Skip("features contain NaN or inf values (joints that coincide or a broken take)")
    return features, recover_from_ric(features, T2M.n_joints).astype(np.float32), rig.name


# --- the dataset ------------------------------------------------------------------------------------------


def _sha1(path: Path) -> str:
    return hashlib.sha1(path.read_bytes()).hexdigest()


def _previous_meta(out: Path) -> dict | None:
    """The meta of an earlier :func:`dataset_from_bvh` run into ``out``, or None if ``out`` is not one."""
    try:
        meta = json.loads((out / "meta.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return meta if isinstance(meta, dict) and meta.get("generator") == GENERATOR else None


def _prepare_out(out: Path, folder: Path, force: bool) -> tuple[dict | None, bool, set[str]]:
    """Judge ``out`` before any work: (meta of a run to resume or None, whether the files this command wrote there
    are to be replaced, the files it wrote there before)."""
    resolved, source = out.resolve(), folder.resolve()
    if resolved == source or resolved in source.parents:
        raise ValueError(f"the output folder {out} must not be the BVH folder or a folder above it")
    if out.exists() and not out.is_dir():
        raise ValueError(f"the output folder {out} exists and is a file")
    existing = out if out.exists() else next(p for p in resolved.parents if p.exists())
    if not os.access(existing, os.W_OK):
        raise ValueError(f"cannot write to {existing} (for the output folder {out}): permission denied")
    if not out.exists() or not any(out.iterdir()):
        return None, False, set()
    previous, ours = _previous_meta(out), written_files(out)
    if force:
        return None, True, ours  # replaced only when the new dataset is complete
    if previous is None:
        raise FileExistsError(
            f"the output folder {out} is not empty and holds no earlier from-bvh dataset; force=True converts "
            "into it anyway (keeping every file the command did not write)"
        )
    return previous, False, ours


def written_files(out: str | os.PathLike) -> set[str]:
    """The files (paths relative to ``out``) that this command wrote into ``out``: its manifest's list, or for a
    dataset written before manifests existed, the files its ``meta.json`` records. Empty for any other folder."""
    out = Path(out)
    try:
        manifest = json.loads((out / MANIFEST).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        manifest = None
    listed = manifest.get("files") if isinstance(manifest, dict) and manifest.get("generator") == GENERATOR else None
    if isinstance(listed, list):
        return {f for f in listed if isinstance(f, str) and _inside(f)}
    previous = _previous_meta(out)
    if previous is None:
        return set()
    clips = previous.get("clips") if isinstance(previous.get("clips"), dict) else {}
    return {f for clip_id in clips for f in _clip_paths(str(clip_id)) if _inside(f)} | set(DATASET_FILES) - {MANIFEST}


def _inside(relative: str) -> bool:
    """A manifest entry names a file inside the folder (no absolute path, no ``..``)."""
    path = Path(relative)
    return not path.is_absolute() and ".." not in path.parts and relative != ""


def _clip_paths(clip_id: str) -> list[str]:
    return [p.as_posix() for p in clip_files(Path(""), clip_id)]


class _Manifest:
    """The manifest of a dataset folder: a file is listed before it is written, so an interrupted run leaves
    nothing unlisted."""

    def __init__(self, out: Path, files: set[str]):
        self.out, self.files = out, set(files) | {MANIFEST}

    def add(self, *relative: str) -> None:
        new = set(relative) - self.files
        if new:
            self.files |= new
            self.save()

    def discard(self, relative: str) -> None:
        self.files.discard(relative)

    def save(self) -> None:
        text = json.dumps(
            {
                "generator": GENERATOR,
                "about": "the files motionlab data from-bvh wrote here; --force replaces these and only these",
                "files": sorted(self.files),
            },
            indent=1,
        )
        write_text_atomic(self.out / MANIFEST, text + "\n")


def _check_foreign_files(out: Path, paths: list[str], ours: set[str]) -> None:
    """Refuse, before any work, a run that would overwrite a file in ``out`` that this command did not write."""
    foreign = [p for p in dict.fromkeys(paths) if p not in ours and (out / p).exists()]
    if foreign:
        raise ValueError(
            f"the output folder {out} holds {plural(len(foreign), 'file')} that the dataset would overwrite but "
            f"that from-bvh did not write: {', '.join(foreign[:5])}{' ...' if len(foreign) > 5 else ''}; move "
            f"{'it' if len(foreign) == 1 else 'them'} away (the files it wrote are listed in {out / MANIFEST})"
        )


def _remove_other_clips(out: Path, keep: set[str], manifest: _Manifest) -> None:
    """Delete clip files of an earlier run whose take has gone (or now fails): the dataset mirrors the folder.
    Only files the manifest lists are candidates."""
    removed = False
    for sub in CLIP_FOLDERS:
        for path in sorted((out / sub).iterdir()):
            relative = f"{sub}/{path.name}"
            if path.stem not in keep and relative in manifest.files:
                path.unlink()
                manifest.discard(relative)
                removed = True
    if removed:
        manifest.save()


def _write_meta(out: Path, meta: dict) -> None:
    write_text_atomic(out / "meta.json", json.dumps(meta, indent=1, sort_keys=True) + "\n")


def _assign_splits(ids: list[str], seed: int) -> tuple[dict[str, list[str]], list[str]]:
    splits = stratified_split({"all": ids}, np.random.default_rng(seed))
    if splits["val"]:
        return splits, []
    note = (
        f"only {plural(len(ids), 'clip')}: val and test repeat the training clips, so scores on them are not "
        "held-out scores; convert at least 3 takes"
    )
    return {"train": list(ids), "val": list(ids), "test": list(ids)}, [note]


class _Progress:
    """One tqdm bar on a terminal; otherwise (a log file) one line per phase."""

    def __init__(self, enabled: bool):
        self.bar_on = enabled and sys.stderr.isatty()
        self.lines_on = enabled and not self.bar_on

    def phase(self, text: str) -> None:
        if self.lines_on:
            print(f"from-bvh: {text}", file=sys.stderr, flush=True)

    def bar(self, total: int):
        return tqdm(total=total, desc="from-bvh", unit="clip", disable=not self.bar_on, file=sys.stderr)


def dataset_from_bvh(
    folder: str | os.PathLike,
    out: str | os.PathLike,
    captions: str | os.PathLike | None = None,
    mapping: str | os.PathLike | Mapping[str, str] = AUTO,
    scale: float | None = None,
    up: str | None = None,
    seed: int = 0,
    force: bool = False,
    progress: bool = True,
) -> FromBvhReport:
    """Convert the BVH takes in ``folder`` into a HumanML3D-layout dataset at ``out`` (see the module docstring).

    ``captions`` is a CSV (``take,caption[,start,end]``) or None for captions from the file names;
    ``mapping``/``scale``/``up`` choose the rig as for :func:`motionlab.io.bvh_to_joints` (``"auto"``: each
    take's rig from its joint names; ``"cmu"``, ``"t2m"``, a dict t2m joint -> BVH joint, which needs ``scale``,
    or a ``.json`` joint map); ``seed`` fixes the split. ``force`` converts into a non-empty ``out`` that is no
    earlier from-bvh dataset, or rebuilds one from scratch; either way only files this command wrote are
    replaced (its manifest). All arguments and ``out`` are judged before any take is read. Returns a
    :class:`FromBvhReport`; raises ``ValueError`` when no take could be converted.
    """
    t0 = time.perf_counter()
    folder, out = Path(folder), Path(out)
    takes = list_takes(folder)
    table = read_captions_csv(captions) if captions is not None else None
    auto = isinstance(mapping, str) and mapping.lower() == AUTO
    check_scale_up(scale, up)
    rig = None if auto else resolve_rig(mapping, scale, up)
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed!r}")
    previous, replace, ours = _prepare_out(out, folder, force)
    plans = plan_clips(takes, table)[0]
    _check_foreign_files(out, [*DATASET_FILES, *(f for plan in plans for f in _clip_paths(plan.clip_id))], ours)
    request = _RigRequest(rig, scale, up)
    if not replace:
        return _build(folder, out, takes, table, request, int(seed), previous, ours, progress, t0)
    # built beside ``out`` and moved in at the end: a run that fails, or is interrupted, leaves ``out`` as it was
    target = out.resolve()
    building = target.with_name(f".{target.name}.from-bvh-{os.getpid()}")
    shutil.rmtree(building, ignore_errors=True)
    try:
        report = _build(folder, building, takes, table, request, int(seed), None, set(), progress, t0)
        _move_in(building, target, ours)
    finally:
        shutil.rmtree(building, ignore_errors=True)
    report.out = out
    return report


def _move_in(building: Path, target: Path, ours: set[str]) -> None:
    """Replace the files this command wrote into ``target`` (``ours``) by the complete dataset in ``building``;
    every other file in ``target`` stays."""
    new = written_files(building)
    for relative in sorted(ours - new):
        (target / relative).unlink(missing_ok=True)
    for relative in sorted(new - {MANIFEST}) + [MANIFEST]:  # the manifest last: it lists what is in place
        destination = target / relative
        destination.parent.mkdir(parents=True, exist_ok=True)
        os.replace(building / relative, destination)


def _build(
    folder: Path,
    out: Path,
    takes: list[Path],
    table: Mapping[str, Mapping[tuple[int, int | None], list[str]]] | None,
    request: _RigRequest,
    seed: int,
    previous: dict | None,
    ours: set[str],
    progress: bool,
    t0: float,
) -> FromBvhReport:
    """Convert into ``out``, resuming ``previous`` (an earlier run's meta) where given; ``ours``: the files an
    earlier run wrote there."""
    existed, fresh = out.exists(), previous is None

    plans, skipped, notes = plan_clips(takes, table)
    settings = {"fps": FPS, **request.settings(), "version": VERSION}
    old_clips = previous["clips"] if previous is not None and previous.get("settings") == settings else {}
    make_layout(out)
    manifest = _Manifest(out, ours | {"meta.json"})  # saved with the first file it adds
    # Clips of the earlier run stay listed until this run decides on them, so an interrupted run loses nothing.
    meta = {
        "generator": GENERATOR,
        "settings": settings,
        "seed": int(seed),
        "complete": False,
        "clips": dict(old_clips),
    }
    report = FromBvhReport(out=out, skipped=skipped, notes=notes)
    show = _Progress(progress)
    show.phase(f"{plural(len(takes), 'take')} in {folder}, {plural(len(plans), 'clip')} to make, into {out}")

    bar = show.bar(len(plans))
    for plan in plans:
        bar.set_postfix_str(plan.clip_id, refresh=False)
        source = {"file": plan.file, "sha1": _sha1(folder / plan.file), "start": plan.start, "end": plan.end}
        lines = [caption_to_line(c) for c in plan.captions]
        old = old_clips.get(plan.clip_id, {})
        if {k: old.get(k) for k in source} == source and all(p.is_file() for p in clip_files(out, plan.clip_id)):
            report.reused[plan.clip_id] = old["frames"]  # captions may have changed: the texts are rewritten
            if request.rig is None and "rig" in old:
                report.rigs[plan.clip_id] = old["rig"]
            write_text_atomic(clip_files(out, plan.clip_id)[2], "".join(f"{line}\n" for line in lines))
        else:
            t = time.perf_counter()
            try:
                converted = convert_clip(folder / plan.file, plan, request)
            except _Skip as why:
                skipped[plan.label] = str(why)
            else:
                features, joints, rig_name = converted
                manifest.add(*_clip_paths(plan.clip_id))  # listed before written
                write_clip(out, plan.clip_id, features, joints, lines)
                report.converted[plan.clip_id] = len(features)
                meta["clips"][plan.clip_id] = {**source, "frames": len(features), "rig": rig_name}
                if request.rig is None:
                    report.rigs[plan.clip_id] = rig_name
                _write_meta(out, meta)  # after every clip: an interrupted run resumes from here
                report.convert_seconds += time.perf_counter() - t
        bar.update()
    bar.close()
    show.phase(
        f"converted {plural(len(report.converted), 'clip')} in {report.convert_seconds:.1f} s, reused "
        f"{len(report.reused)}, skipped {len(skipped)}"
    )

    ids = report.clips
    if not ids:  # nothing converted or reused: ``out`` is left as it was (absent, empty, or the earlier dataset)
        if fresh:  # it was absent or empty
            shutil.rmtree(out, ignore_errors=True)
            if existed:
                out.mkdir()
        reasons = "; ".join(f"{name}: {why}" for name, why in list(skipped.items())[:5])
        more = f" (+{len(skipped) - 5} more)" if len(skipped) > 5 else ""
        if len(takes) == 1:
            head = f"the only take in {folder} could not be converted"
        else:
            head = f"none of the {len(takes)} takes in {folder} could be converted"
        raise ValueError(f"{head} ({reasons}{more})")
    meta["clips"] = {i: meta["clips"][i] for i in ids}
    _remove_other_clips(out, set(ids), manifest)

    splits, split_notes = _assign_splits(ids, int(seed))
    report.notes += split_notes
    manifest.add(*DATASET_FILES)
    write_split_files(out, {**splits, "all": ids})
    Normalizer.fit([np.load(clip_files(out, i)[0]) for i in splits["train"]], T2M).save(out)
    report.splits = {name: len(v) for name, v in splits.items()}
    meta.update(complete=True, skipped=dict(sorted(skipped.items())), splits=report.splits)
    _write_meta(out, meta)
    report.seconds = time.perf_counter() - t0
    show.phase(f"wrote splits ({', '.join(f'{k} {v}' for k, v in report.splits.items())}) and Mean/Std")
    return report
