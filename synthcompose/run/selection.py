"""Which image sets a manifest selects; a selector that selects nothing is refused, naming it.

A typo in a split, city or frame name would otherwise select nothing and the batch would end
"0 done" with exit status 0. Each selector entry must match: one that does not is named with
the nearest names there are (:func:`difflib.get_close_matches`), and the batch stops before any
work (:class:`~.errors.ManifestError`, exit 2).
"""
from __future__ import annotations

import difflib
from pathlib import Path

from synthcompose.errors import ManifestError
from synthcompose.io.dataset import ImageSetId, find_image_sets, nfc, subfolders
from synthcompose.manifest import Manifest

#: at most this many selector entries are explained in one error (the rest are counted)
EXPLAINED = 5


def near(word: str, names) -> str:
    """``"; did you mean 'a' or 'b'?"`` for the names near ``word``, or ``""``."""
    close = difflib.get_close_matches(nfc(word), sorted({nfc(n) for n in names}), n=3, cutoff=0.6)
    return f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""


def _listing(names, most: int = 8) -> str:
    names = sorted(set(names))
    shown = ", ".join(repr(n) for n in names[:most])
    return shown + (f" and {len(names) - most} more" if len(names) > most else "") if names else "none"


def _split_problems(m: Manifest, there: list[str]) -> list[str]:
    folder = Path(m.dataset) / "leftImg8bit"
    return [f"field 'splits': {s!r} matches no split folder of {folder} (there: {_listing(there)}){near(s, there)}"
            for s in m.splits or () if s not in there]


def _city_problems(m: Manifest, everything: list[ImageSetId], cities_there: set[str]) -> list[str]:
    with_sets = {nfc(i.city) for i in everything}
    out = []
    for c in m.cities or ():
        if nfc(c) not in cities_there:
            out.append(f"field 'cities': {c!r} matches no city folder of the selected splits "
                       f"(there: {_listing(cities_there)}){near(c, cities_there)}")
        elif nfc(c) not in with_sets:
            out.append(f"field 'cities': the city folder {c!r} holds no <city>_<seq>_<frame>_leftImg8bit.png photo")
    if m.cities is not None and not m.cities:
        out.append("field 'cities': an empty list selects no image set (leave the field out for every city)")
    return out


def _frame_problems(m: Manifest, candidates: list[ImageSetId], everything: list[ImageSetId]) -> list[str]:
    """``candidates``: the image sets of the selected splits and cities; ``everything``: of
    the selected splits."""
    chosen = {nfc(i.name) for i in candidates}
    elsewhere = {nfc(i.name): i for i in everything}
    out = []
    for f in m.frames or ():
        if nfc(f) in chosen:
            continue
        if nfc(f) in elsewhere:
            out.append(f"field 'frames': {f!r} is in city {elsewhere[nfc(f)].city!r}, which field 'cities' leaves out")
            continue
        city, seq, frame = f.rsplit("_", 2)
        camera = [ImageSetId(s, city, seq, frame) for s in {i.split for i in everything}]
        partial = [i for i in camera if i.path(m.dataset, "camera").exists() or i.path(m.dataset, "disparity").exists()]
        if partial:
            out.append(f"field 'frames': {f!r} has no left photo ({partial[0].path(m.dataset, 'rgb')} is missing)")
        else:
            out.append(f"field 'frames': {f!r} matches no image set of the selected splits and cities"
                       f"{near(f, chosen) or ' (no name is near it)'}")
    if m.frames is not None and not m.frames:
        out.append("field 'frames': an empty list selects no image set (leave the field out for every frame)")
    return out


def select_image_sets(m: Manifest) -> list[ImageSetId]:
    """The image sets ``m`` selects (before its ``limit``), sorted; a :class:`ManifestError`
    naming each split, city or frame that matches nothing (with the names near it), or saying
    that the dataset holds no image set at all. What is selected must be readable (a folder that
    cannot be listed is an error naming it); what is not is only listed to explain."""
    root = Path(m.dataset)
    find_image_sets(root, [])  # the dataset root and its leftImg8bit folder are there
    problems: list[str] = []
    selected: list[ImageSetId] = []
    if m.splits and not all((root / "leftImg8bit" / s).is_dir() for s in m.splits):
        problems = _split_problems(m, [p.name for p in subfolders(root / "leftImg8bit", skip_broken=True)])
    if not problems:
        selected = find_image_sets(root, m.splits, m.cities, m.frames)
        if selected and m.cities is None and m.frames is None:
            return selected
        splits = list(m.splits) if m.splits else [p.name for p in subfolders(root / "leftImg8bit", skip_broken=True)]
        everything = find_image_sets(root, splits, skip_broken=True)
        cities_there = {nfc(p.name) for s in splits for p in subfolders(root / "leftImg8bit" / s, skip_broken=True)}
        in_cities = [i for i in everything if m.cities is None or nfc(i.city) in {nfc(c) for c in m.cities}]
        problems = _city_problems(m, everything, cities_there) + _frame_problems(m, in_cities, everything)
        if not problems and not selected:
            problems = [f"selects no image set: {root / 'leftImg8bit'} holds no "
                        "<split>/<city>/<city>_<seq>_<frame>_leftImg8bit.png photo"]
    if problems:
        more = len(problems) - EXPLAINED
        raise ManifestError(m.path, "; ".join(problems[:EXPLAINED]) + (f"; and {more} more" if more > 0 else ""))
    return selected
