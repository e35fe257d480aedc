"""Named splits: the manifests in ``seeds/*.toml``, resolved by name, and where their scenes go.

A *split* is one :class:`~citygen.spec.config.SplitConfig` (``urban-nav-2-train``); a
*family* is every split whose name starts with ``NAME-`` (``urban-nav-2`` is the train and
test parts, ``urban-nav`` all six Urban-Nav parts). Scene ``i`` of split ``s`` with master
seed ``m`` has the seed :func:`~citygen.seeding.scene_seed` ``(m, s, i)``, written into its
``meta`` with the split's name and the index, so a scene file says how to make it again.

Files go to ``OUT/<family>/<part>/<index:04d>.json`` where the split's name ends in
``-train`` or ``-test`` (``out/urban-nav-2/train/0000.json``) and to
``OUT/<name>/<index:04d>.json`` otherwise (``out/urban-tra-city/0000.json``).

>>> s = splits()["urban-nav-2-train"]
>>> s.scenes, s.config.placement.count, s.config.placement.density_levels
(256, 4, (0.5, 1.0, 1.5))
>>> [p.name for p in resolve("urban-nav-2")]
['urban-nav-2-train', 'urban-nav-2-test']
>>> relative_path("urban-nav-2-train", 7).as_posix()
'urban-nav-2/train/0007.json'
"""

from __future__ import annotations

import functools
from pathlib import Path, PurePosixPath

from citygen.errors import Problem, SpecError
from citygen.io import load_manifest, parse, read_document
from citygen.spec.config import GeneratorConfig, SplitConfig, SplitManifest, check_config
from citygen.spec.limits import MAX_RUN_SCENES, MAX_SCENE_INDEX
from citygen.spec.scene import Scene

#: Suffixes that name the part of a split within its family (the folder it is written to).
PARTS = ("train", "test")


def seeds_dir() -> Path:
    """The folder of the split manifests: ``citygen/seeds`` in an installed wheel (mapped by
    pyproject's package-dir), the repository's ``seeds/`` in a checkout."""
    package = Path(__file__).resolve().parent.parent
    for candidate in (package / "seeds", package.parent / "seeds"):
        if candidate.is_dir() and any(candidate.glob("*.toml")):
            return candidate
    raise SpecError(
        [Problem("$", "a seeds/ folder of split manifests beside the citygen package", "none found")],
        file=str(package.parent / "seeds"),
    )


@functools.cache
def _manifests(folder: Path) -> tuple[tuple[Path, SplitManifest], ...]:
    return tuple((path, load_manifest(path)) for path in sorted(folder.glob("*.toml")))


def manifests() -> tuple[tuple[Path, SplitManifest], ...]:
    """Every manifest in :func:`seeds_dir`, by file name, each loaded and checked once."""
    return _manifests(seeds_dir())


def splits() -> dict[str, SplitConfig]:
    """Every named split of the manifests in ``seeds/``, in file order, then manifest order.

    Raises :class:`~citygen.errors.SpecError` if two manifests define the same name.
    """
    found: dict[str, SplitConfig] = {}
    where: dict[str, Path] = {}
    for path, manifest in manifests():
        for split in manifest.splits:
            if split.name in found:
                raise SpecError(
                    [
                        Problem(
                            "$.splits", f"a split name defined once (also in {where[split.name]})", split.name
                        )
                    ],
                    file=str(path),
                )
            found[split.name] = split
            where[split.name] = path
    return found


def families() -> dict[str, tuple[str, ...]]:
    """Every name that means several splits (each prefix ending before a ``-``), to its parts.

    >>> families()["urban-nav-2"]
    ('urban-nav-2-train', 'urban-nav-2-test')
    """
    out: dict[str, list[str]] = {}
    for name in splits():
        words = name.split("-")
        for k in range(1, len(words)):
            out.setdefault("-".join(words[:k]), []).append(name)
    return {k: tuple(v) for k, v in out.items() if k not in splits()}


def known_names() -> list[str]:
    """Split and family names a user may pass, for error messages (families with 2+ parts)."""
    fams = [f for f, parts in families().items() if f.count("-") >= 1 and len(parts) > 1]
    return sorted({*splits(), *fams})


def resolve(name_or_path: str | Path, *, seed: int | None = None) -> list[SplitConfig]:
    """The splits ``name_or_path`` means: a split name, a family name, or a file.

    A file (``.toml`` or ``.json``) is either a split manifest (a document with ``splits``)
    or a user's own :class:`~citygen.spec.config.GeneratorConfig`; a config becomes one
    split named after the file's stem with one scene and master seed 0. ``seed`` replaces
    every split's master seed. Raises :class:`~citygen.errors.SpecError` for an unknown
    name (listing the known ones) or a bad file.
    """
    text = str(name_or_path)
    table = splits()
    if text in table:
        found = [table[text]]
    elif text in families() and len(families()[text]) >= 1 and "-" in text:
        found = [table[n] for n in families()[text]]
    elif Path(text).suffix.lower() in (".toml", ".json") or Path(text).is_file():
        found = _from_file(Path(text))
    else:
        raise SpecError(
            [
                Problem(
                    "--split",
                    f"a split ({', '.join(known_names())}) or a config file (.toml, .json)",
                    repr(text),
                )
            ]
        )
    if seed is not None:
        found = [s.model_copy(update={"seed": seed}) for s in found]
    return found


def _from_file(path: Path) -> list[SplitConfig]:
    document = read_document(path)
    if isinstance(document, dict) and "splits" in document:
        return list(load_manifest(path).splits)
    config = parse(GeneratorConfig, document, file=str(path))
    problems = check_config(config)
    if problems:
        raise SpecError(problems, file=str(path))
    name = "".join(c if c.isalnum() or c in "-_" else "-" for c in path.stem.lower()).strip("-_") or "scene"
    return [SplitConfig(name=name, scenes=1, seed=0, config=config)]


def config_for(scene: Scene, config_file: str | Path | None = None) -> GeneratorConfig:
    """The generator config a scene was made from, for :func:`~citygen.generate.pipeline.rebuild`.

    Without ``config_file``: the config of the named split in the scene's ``meta.split``.
    With one: a user's generator config (TOML or JSON), or a split manifest, whose split
    named ``meta.split`` (or whose only split) is taken. Raises
    :class:`~citygen.errors.SpecError` when neither says which config it is.

    >>> import citygen
    >>> config_for(citygen.generate("urban-nav-2-test", index=1)).placement.count
    8
    """
    split = scene.meta.split
    if config_file is not None:
        found = _from_file(Path(config_file))
        if len(found) == 1:
            return found[0].config
        named = [s for s in found if s.name == split]
        if named:
            return named[0].config
        names = ", ".join(s.name for s in found)
        raise SpecError(
            [Problem("$.splits", f"a split named {split!r} (the scene's meta.split)", names)],
            file=str(config_file),
        )
    if split is None:
        raise SpecError(
            [Problem("$.meta.split", "the named split the scene came from (or give --config FILE)", "none")]
        )
    table = splits()
    if split not in table:
        raise SpecError(
            [Problem("$.meta.split", "a split of seeds/*.toml (or give --config FILE)", repr(split))]
        )
    return table[split].config


def relative_path(split: str, index: int) -> PurePosixPath:
    """Where scene ``index`` of ``split`` goes under an output folder (see the module docstring)."""
    family, _, part = split.rpartition("-")
    if family and part in PARTS:
        return PurePosixPath(family, part, f"{index:04d}.json")
    return PurePosixPath(split, f"{index:04d}.json")


def indices(split: SplitConfig, index: int | None = None, count: int | None = None) -> range:
    """The scene indices to make: ``count`` from ``index``; by default scene ``index`` alone
    when an index is given, else every scene of the split. Indices past ``split.scenes``
    extend the split with the same seed derivation, up to index
    :data:`~citygen.spec.limits.MAX_SCENE_INDEX`; a run holds at most
    :data:`~citygen.spec.limits.MAX_RUN_SCENES` scenes."""
    if index is not None and not 0 <= index <= MAX_SCENE_INDEX:
        raise SpecError([Problem("--index", f"an index from 0 to {MAX_SCENE_INDEX:,}", f"{index:,}")])
    if count is not None and not 1 <= count <= MAX_RUN_SCENES:
        raise SpecError([Problem("--count", f"a count from 1 to {MAX_RUN_SCENES:,}", f"{count:,}")])
    start = index or 0
    n = count if count is not None else (1 if index is not None else split.scenes)
    if n > MAX_RUN_SCENES:
        raise SpecError([Problem(
            f"{split.name}: scenes", f"at most {MAX_RUN_SCENES:,} scenes in one run (give --index and "
            "--count to make a part)", f"{n:,}",
        )])  # fmt: skip
    if start + n - 1 > MAX_SCENE_INDEX:
        last = f"{start:,} + {n:,} scenes, up to {start + n - 1:,}"
        raise SpecError([Problem("--index", f"scenes up to index {MAX_SCENE_INDEX:,}", last)])
    return range(start, start + n)
