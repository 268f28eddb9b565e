"""The slice of the manifest each stage reads, typed and frozen: made once per pipeline from the
resolved :class:`~synthcompose.manifest.Manifest` (:meth:`StageOptions.of`), so that a stage
sees only what decides its own work."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from synthcompose.lighting import fixed_record
from synthcompose.lighting.light import Lighting
from synthcompose.manifest import Manifest, ObjectSpec
from synthcompose.placement import PlacementRules


@dataclass(frozen=True)
class ReadOptions:
    """:func:`stages.prepare` and :func:`stages.measure_light`: where the image sets are, which
    photos to read, what to measure of the photo's light."""

    dataset: Path
    seed: int
    right_view: bool  # read the right photo of the pair (where the input has one)
    estimate_light: bool  # lighting mode "estimate": the photo's own light
    camera_match: bool  # measure the camera's blur, noise and tones


@dataclass(frozen=True)
class PlaceOptions:
    """:func:`stages.place`: the objects to draw, the rules, and the record's first part."""

    dataset: Path
    seed: int
    objects: tuple[ObjectSpec, ...]
    objects_per_image: int
    rules: PlacementRules
    light_record: tuple[tuple[str, Any], ...]  # the record's light before any estimate: (key, value)
    config_hash: str
    redraw_unplaced: bool = True  # an object without a place is replaced by one that stands elsewhere


@dataclass(frozen=True)
class ShadeOptions:
    """:func:`stages.shade`: the light when none is estimated, and how the estimate is used."""

    seed: int
    lighting: Lighting
    match_exposure: bool


@dataclass(frozen=True)
class WriteOptions:
    """:func:`stages.write_done` / :func:`stages.write_skipped`: where the outputs go (and the
    inputs the annotations copy from)."""

    dataset: Path
    output: Path


@dataclass(frozen=True)
class StageOptions:
    read: ReadOptions
    place: PlaceOptions
    shade: ShadeOptions
    write: WriteOptions

    @classmethod
    def of(cls, m: Manifest) -> "StageOptions":
        fixed = m.lighting_mode == "fixed"
        light = fixed_record(m.lighting, **dict(m.lighting_keys)) if fixed else {"mode": "estimate"}
        return cls(ReadOptions(m.dataset, m.seed, m.right_view, m.lighting_mode == "estimate", m.camera_match),
                   PlaceOptions(m.dataset, m.seed, m.objects, m.objects_per_image, m.rules, tuple(light.items()),
                                m.config_hash, m.redraw_unplaced),
                   ShadeOptions(m.seed, m.lighting, m.match_exposure),
                   WriteOptions(m.dataset, m.output))
