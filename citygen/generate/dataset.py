"""Writing many scenes: a process pool, resumable runs, the canonical dataset and its lock file.

:func:`write_scenes` makes every (split, index) scene and writes it atomically to
``OUT/<family>/<part>/<index:04d>.json`` (:func:`citygen.generate.splits.relative_path`),
many scenes per pool task. With ``resume=True`` a scene whose file is already there and
valid is not made again: valid means the SHA-256 digest the lock file records for it,
or, for scenes no lock records, a file that parses as a scene with the expected split,
index, seed and generator. A killed run leaves only whole files (and at worst hidden
``.*.tmp`` files, which the next run removes), so running again with ``resume=True``
finishes the job.

Two executors run the same chunks: ``local`` (a process pool on this machine, each worker
writing its own files) and ``ray`` (:func:`ray_scenes`: one Ray task per chunk on the cluster
``RAY_ADDRESS`` names, or on a Ray started here with ``jobs`` CPUs; the tasks return the
scene bytes and this process writes them, so the output folder need not be shared with the
cluster). Either way a scene's bytes depend only on its split and index.

The canonical dataset is every split of ``seeds/urban-nav.toml`` (1,536 scenes) with its
manifest's master seeds. Its digests live in ``seeds/urban-nav.lock.json``; after a
deliberate change to the generator regenerate them with ``citygen dataset lock`` and say
in the commit message what changed. ``citygen dataset verify DIR`` compares a folder with
the lock file.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

from citygen.errors import CitygenError, DependencyMissing, Problem, SpecError
from citygen.generate.pipeline import GENERATOR
from citygen.generate.splits import generate_scene, indices, relative_path, seeds_dir
from citygen.io import dumps, load_manifest, load_scene, write_atomic
from citygen.seeding import scene_seed
from citygen.spec.config import SplitConfig
from citygen.workers import check_interrupted, die_with_parent, interrupt_only_in

LOCK_FORMAT = "citygen.lock/1"
INDEX_FORMAT = "citygen.dataset/1"
INDEX_NAME = "index.json"
#: The manifest of the canonical dataset, in :func:`~citygen.generate.splits.seeds_dir`.
DATASET_MANIFEST = "urban-nav.toml"
#: Most scenes one pool task makes (fewer when there are few scenes per worker).
MAX_CHUNK = 32
#: Where scenes can be made: a process pool here, or a Ray cluster.
EXECUTORS = ("local", "ray")


@dataclass(frozen=True)
class Written:
    """One scene of a run: where it is (relative to the output folder, ``/``-separated),
    what it is, its SHA-256 digest, and whether a valid file was already there."""

    path: str
    split: str
    index: int
    seed: int
    sha256: str
    skipped: bool = False


def sha256(data: bytes) -> str:
    """Hex SHA-256 digest of ``data``."""
    return hashlib.sha256(data).hexdigest()


def default_jobs() -> int:
    """Worker processes by default: every core this process may run on."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not Linux
        return max(1, os.cpu_count() or 1)


# --- making scenes ----------------------------------------------------------------------


def _valid_existing(
    path: Path, split: SplitConfig, index: int, seed: int, expected: str | None
) -> str | None:
    """The digest of the file already at ``path`` if it is the scene wanted there, else None."""
    try:
        data = path.read_bytes()
    except OSError:
        return None
    digest = sha256(data)
    if expected is not None:
        return digest if digest == expected else None
    try:
        meta = load_scene(path).meta
    except CitygenError:
        return None
    same = (meta.split, meta.index, meta.seed, meta.generator) == (split.name, index, seed, GENERATOR)
    return digest if same else None


def _make_chunk(
    split: SplitConfig, chunk: Sequence[int], out: str, resume: bool, expected: dict[str, str]
) -> list[Written]:
    """Make (or, resuming, keep) scenes ``chunk`` of ``split``; runs in a pool worker."""
    done = []
    for i in chunk:
        check_interrupted()  # Ctrl-C reached this worker: start no new scene
        if _STOP is not None and _STOP.is_set():  # the run was interrupted: start no new scene
            raise KeyboardInterrupt
        rel = relative_path(split.name, i).as_posix()
        path = Path(out, rel)
        seed = scene_seed(split.seed, split.name, i)
        if resume:
            digest = _valid_existing(path, split, i, seed, expected.get(rel))
            if digest is not None:
                done.append(Written(rel, split.name, i, seed, digest, skipped=True))
                continue
        data = _scene_bytes(split, i)
        write_atomic(path, data)
        done.append(Written(rel, split.name, i, seed, sha256(data)))
    return done


def _scene_bytes(split: SplitConfig, index: int) -> bytes:
    """The file of scene ``index`` of ``split``; a failure as a plain, picklable CitygenError."""
    try:
        return dumps(generate_scene(split, index)).encode("utf-8")
    except CitygenError as exc:
        # Exceptions with custom constructors do not survive pickling: send the text.
        raise CitygenError(f"{relative_path(split.name, index).as_posix()}: {exc}") from None


def _ray_chunk(split: SplitConfig, chunk: Sequence[int]) -> list[tuple[int, bytes]]:
    """One Ray task: the files of scenes ``chunk`` of ``split``, by index."""
    return [(i, _scene_bytes(split, i)) for i in chunk]


#: In a pool worker: set by the process that started the pool when its run is interrupted.
_STOP = None


def _die_with_parent(stop=None) -> None:
    """Pool initializer: a worker ends when the process that started it is killed (Linux),
    starts no new scene once ``stop`` (a multiprocessing Event) is set, and takes Ctrl-C only
    while it makes scenes (:mod:`citygen.workers`)."""
    global _STOP
    _STOP = stop
    interrupt_only_in(_make_chunk)
    die_with_parent()


def chunks(work: list[tuple[SplitConfig, int]], jobs: int) -> Iterator[tuple[SplitConfig, list[int]]]:
    """The tasks of a run, for the process pool and for Ray alike: runs of consecutive scenes of
    one split, about four per worker (``jobs``), each at most :data:`MAX_CHUNK` scenes."""
    size = max(1, min(MAX_CHUNK, -(-len(work) // (jobs * 4))))
    current: list[int] = []
    owner: SplitConfig | None = None
    for split, i in work:
        if owner is not None and (split is not owner or len(current) >= size):
            yield owner, current
            current = []
        owner = split
        current.append(i)
    if owner is not None and current:
        yield owner, current


def _clean_temporaries(out: Path, rels: set[str]) -> None:
    """Remove the hidden temporary files a killed run left beside the scenes it was writing,
    and beside the dataset's index in ``out`` (a kill while it was written)."""
    for folder in sorted({str(Path(out, r).parent) for r in rels} | {str(Path(out))}):
        for tmp in Path(folder).glob(".*.json.*.tmp"):
            tmp.unlink(missing_ok=True)


def write_scenes(
    splits: Sequence[SplitConfig],
    out: str | Path,
    *,
    index: int | None = None,
    count: int | None = None,
    jobs: int | None = None,
    resume: bool = False,
    expected: dict[str, str] | None = None,
    on_progress: Callable[[int], None] | None = None,
    executor: str = "local",
) -> list[Written]:
    """Make scenes ``index .. index + count`` of every split (see
    :func:`~citygen.generate.splits.indices`) and write each to ``out`` atomically.

    ``jobs``: worker processes (default :func:`default_jobs`; 1 works in this process), or
    the CPUs of a Ray started here. ``resume``: keep files already there and valid
    (``expected`` maps relative paths to the digests they must have). ``on_progress(n)`` is
    called as ``n`` more scenes are done. ``executor``: ``local`` or ``ray`` (see the module
    docstring; ``ray`` needs the ``scale`` extra). Returns one :class:`Written` per scene, in
    split and index order.
    """
    out = Path(out)
    expected = expected or {}
    check_executor(executor)
    if jobs is not None and jobs < 1:
        raise SpecError([Problem("--jobs", "at least 1 worker", str(jobs))])
    work = [(s, i) for s in splits for i in indices(s, index, count)]
    if executor == "ray":
        return ray_scenes(work, out, jobs=jobs, resume=resume, expected=expected, on_progress=on_progress)
    rels = {relative_path(s.name, i).as_posix() for s, i in work}
    _clean_temporaries(out, rels)
    jobs = default_jobs() if jobs is None else jobs
    results: list[Written] = []
    if jobs == 1 or len(work) <= 1:
        for split, chunk in chunks(work, 1):
            for w in _make_chunk(split, chunk, str(out), resume, expected):
                results.append(w)
                if on_progress:
                    on_progress(1)
    else:
        import multiprocessing

        methods = multiprocessing.get_all_start_methods()
        # fork: workers start with citygen already imported (seconds saved per worker).
        context = multiprocessing.get_context("fork" if "fork" in methods else None)
        stop = context.Event()
        with ProcessPoolExecutor(
            jobs, mp_context=context, initializer=_die_with_parent, initargs=(stop,)
        ) as pool:
            futures = [
                pool.submit(
                    _make_chunk,
                    split,
                    chunk,
                    str(out),
                    resume,
                    {r: expected[r] for r in _rels(split, chunk) if r in expected},
                )
                for split, chunk in chunks(work, jobs)
            ]
            try:
                for future in as_completed(futures):
                    done = future.result()
                    results += done
                    if on_progress:
                        on_progress(len(done))
            except BaseException:
                stop.set()
                for f in futures:
                    f.cancel()
                raise
    order = {(s.name, i): k for k, (s, i) in enumerate(work)}
    return sorted(results, key=lambda w: order[(w.split, w.index)])


def _rels(split: SplitConfig, chunk: Sequence[int]) -> list[str]:
    return [relative_path(split.name, i).as_posix() for i in chunk]


def check_executor(executor: str) -> None:
    """Raise a one-line error, before anything is written, for an unknown executor or for
    ``ray`` without the ``ray`` package (:class:`~citygen.errors.DependencyMissing`)."""
    if executor not in EXECUTORS:
        raise SpecError([Problem("--executor", f"one of {', '.join(EXECUTORS)}", repr(executor))])
    if executor == "ray":
        _import_ray()


def _import_ray():
    try:
        import ray
    except ImportError:
        raise DependencyMissing("ray", "--executor ray", extra="scale") from None
    return ray


def ray_scenes(
    work: Sequence[tuple[SplitConfig, int]],
    out: str | Path,
    *,
    jobs: int | None = None,
    resume: bool = False,
    expected: dict[str, str] | None = None,
    on_progress: Callable[[int], None] | None = None,
) -> list[Written]:
    """Make the ``(split, index)`` scenes of ``work`` on Ray and write them under ``out``.

    Scenes already there and valid are kept when resuming (checked here, before any task is
    sent). The rest go out in :func:`chunks` of consecutive scenes, one Ray task each; this
    process writes every file a task returns, atomically. Uses the Ray already initialised in
    this process, or connects to the cluster at ``RAY_ADDRESS`` (``auto`` finds the one
    ``ray start`` began on this machine), or starts Ray here with ``jobs`` CPUs (default
    :func:`default_jobs`); a Ray it connected to or started is shut down at the end.
    Raises :class:`~citygen.errors.DependencyMissing` without the ``ray`` package.
    """
    ray = _import_ray()
    out = Path(out)
    expected = expected or {}
    _clean_temporaries(out, {relative_path(s.name, i).as_posix() for s, i in work})
    results: list[Written] = []
    todo: list[tuple[SplitConfig, int]] = []
    for split, i in work:
        rel = relative_path(split.name, i).as_posix()
        seed = scene_seed(split.seed, split.name, i)
        digest = _valid_existing(out / rel, split, i, seed, expected.get(rel)) if resume else None
        if digest is None:
            todo.append((split, i))
            continue
        results.append(Written(rel, split.name, i, seed, digest, skipped=True))
        if on_progress:
            on_progress(1)
    started = bool(todo) and not ray.is_initialized()
    if started:
        _start_ray(ray, jobs)
    try:
        if todo:
            results += _run_on_ray(ray, todo, out, on_progress)
    finally:
        if started:
            ray.shutdown()
    order = {(s.name, i): k for k, (s, i) in enumerate(work)}
    return sorted(results, key=lambda w: order[(w.split, w.index)])


def _start_ray(ray, jobs: int | None) -> None:
    """Connect to the cluster at ``RAY_ADDRESS`` (``auto``: the one ``ray start`` began on this
    machine), else start Ray here with ``jobs`` CPUs."""
    import logging

    quiet = {"include_dashboard": False, "logging_level": logging.WARNING, "log_to_driver": False}
    address = os.environ.get("RAY_ADDRESS")
    try:
        if address:
            ray.init(**quiet)
        else:
            ray.init(address="local", num_cpus=jobs or default_jobs(), **quiet)
    except (ConnectionError, ValueError, RuntimeError) as exc:
        where = f"the Ray cluster at RAY_ADDRESS={address}" if address else "a local Ray"
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise CitygenError(f"--executor ray: could not start or reach {where}: {first}") from None


def _run_on_ray(ray, todo, out: Path, on_progress) -> list[Written]:
    workers = max(1, int(ray.cluster_resources().get("CPU", 1)))
    task = ray.remote(num_cpus=1, max_retries=0)(_ray_chunk)
    pending = {task.remote(split, chunk): split for split, chunk in chunks(todo, workers)}
    done: list[Written] = []
    try:
        while pending:
            ready, _ = ray.wait(list(pending), num_returns=1)
            split = pending.pop(ready[0])
            try:
                files = ray.get(ready[0])
            except ray.exceptions.RayTaskError as exc:
                cause = getattr(exc, "cause", None)
                if isinstance(cause, CitygenError):
                    raise CitygenError(str(cause.args[0]) if cause.args else str(cause)) from None
                raise
            for i, data in files:
                rel = relative_path(split.name, i).as_posix()
                write_atomic(out / rel, data)
                done.append(Written(rel, split.name, i, scene_seed(split.seed, split.name, i), sha256(data)))
            if on_progress:
                on_progress(len(files))
    except BaseException:
        for ref in pending:
            ray.cancel(ref, force=True)
        raise
    return done


def rich_bar(*fields: str):
    """A rich ``Progress`` on stderr: description, bar, done/total, the text ``fields`` (rich
    column templates such as ``"{task.fields[rate]} scenes/s"``), elapsed time and ETA; the
    frame of every citygen progress bar."""
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TextColumn,
        TimeElapsedColumn,
        TimeRemainingColumn,
    )

    columns = (
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        *(TextColumn(f) for f in fields),
        TimeElapsedColumn(),
        TextColumn("ETA"),
        TimeRemainingColumn(),
    )
    return Progress(*columns, console=Console(stderr=True), transient=False)


@contextmanager
def progress_bar(total: int, label: str, enabled: bool = True) -> Iterator[Callable[[int], None]]:
    """A rich progress bar (scenes done, scenes/s, ETA) on stderr; yields ``advance(n)``."""
    if not enabled:
        yield lambda n: None
        return
    with rich_bar("{task.fields[rate]} scenes/s") as bar:
        task = bar.add_task(label, total=total, rate="-")

        def advance(n: int) -> None:
            bar.advance(task, n)
            speed = bar.tasks[task].speed
            bar.update(task, rate=f"{speed:.1f}" if speed else "-")

        yield advance


# --- the canonical dataset -----------------------------------------------------------------


def dataset_manifest(manifest: str | Path | None = None) -> Path:
    """The manifest of a dataset: ``manifest`` or ``seeds/urban-nav.toml``."""
    return Path(manifest) if manifest is not None else seeds_dir() / DATASET_MANIFEST


def lock_path(manifest: str | Path | None = None) -> Path:
    """The lock file beside a manifest: ``seeds/urban-nav.lock.json`` for ``urban-nav.toml``."""
    m = dataset_manifest(manifest)
    return m.with_name(m.name.removesuffix(".toml") + ".lock.json")


def read_lock(path: str | Path) -> dict[str, str]:
    """The digests a lock file records, by relative path (``{}`` if there is no lock file)."""
    path = Path(path)
    if not path.is_file():
        return {}
    from citygen.io import read_json

    document = read_json(path)
    if not isinstance(document, dict) or document.get("format") != LOCK_FORMAT:
        raise SpecError(
            [
                Problem(
                    "$.format",
                    repr(LOCK_FORMAT),
                    repr(document.get("format") if isinstance(document, dict) else document),
                )
            ],
            file=str(path),
        )
    files = document.get("files")
    if not isinstance(files, dict) or not all(isinstance(v, str) for v in files.values()):
        raise SpecError(
            [Problem("$.files", "an object of relative paths to hex digests", "something else")],
            file=str(path),
        )
    return files


def _json_bytes(document: dict) -> bytes:
    return (json.dumps(document, indent=1, sort_keys=False, ensure_ascii=False) + "\n").encode("utf-8")


def write_dataset(
    out: str | Path,
    *,
    manifest: str | Path | None = None,
    jobs: int | None = None,
    resume: bool = False,
    on_progress: Callable[[int], None] | None = None,
    executor: str = "local",
) -> list[Written]:
    """Write every scene of a manifest's splits (default: the 1,536 Urban-Nav scenes) with
    its canonical seeds under ``out``, then ``out/index.json`` listing each file, its split,
    index, seed and digest. Resuming checks existing files against the lock file's digests.
    ``executor``: ``local`` or ``ray`` (:func:`write_scenes`).
    """
    m = dataset_manifest(manifest)
    splits = list(load_manifest(m).splits)
    written = write_scenes(
        splits,
        out,
        jobs=jobs,
        resume=resume,
        expected=read_lock(lock_path(m)),
        on_progress=on_progress,
        executor=executor,
    )
    index = {
        "format": INDEX_FORMAT,
        "generator": GENERATOR,
        "manifest": m.name,
        "scenes": len(written),
        "files": [
            {"path": w.path, "split": w.split, "index": w.index, "seed": w.seed, "sha256": w.sha256}
            for w in written
        ],
    }
    write_atomic(Path(out, INDEX_NAME), _json_bytes(index))
    return written


def dataset_size(manifest: str | Path | None = None) -> int:
    """Scenes in a dataset: the sum of its splits' scene counts."""
    return sum(s.scenes for s in load_manifest(dataset_manifest(manifest)).splits)


def write_lock(
    written: Sequence[Written], manifest: str | Path | None = None, path: str | Path | None = None
) -> Path:
    """Record the digests of a dataset run in its lock file (default beside the manifest)."""
    m = dataset_manifest(manifest)
    target = Path(path) if path is not None else lock_path(m)
    document = {
        "format": LOCK_FORMAT,
        "generator": GENERATOR,
        "manifest": m.name,
        "regenerate": "citygen dataset lock",
        "scenes": len(written),
        "files": {w.path: w.sha256 for w in written},
    }
    write_atomic(target, _json_bytes(document))
    return target


def verify_dataset(
    out: str | Path, *, manifest: str | Path | None = None, lock: str | Path | None = None
) -> list[Problem]:
    """Problems of a dataset folder against its lock file: files missing, files whose digest
    differs, scene files the lock does not list. An empty list means the folder is exact."""
    m = dataset_manifest(manifest)
    lock_file = Path(lock) if lock is not None else lock_path(m)
    digests = read_lock(lock_file)
    if not digests:
        return [Problem(str(lock_file), "a lock file of digests (run 'citygen dataset lock')", "none")]
    out = Path(out)
    if not out.is_dir():
        found = "a file" if out.exists() else "no such folder"
        return [Problem(str(out), "a folder 'citygen dataset' wrote", found)]
    problems = []
    for rel, digest in digests.items():
        path = out / rel
        try:
            found = sha256(path.read_bytes())
        except FileNotFoundError:
            problems.append(Problem(str(path), "a scene file", "no such file"))
            continue
        if found != digest:
            problems.append(Problem(str(path), f"sha256 {digest} (from {lock_file.name})", f"sha256 {found}"))
    if len(problems) == len(digests) and all(p.found == "no such file" for p in problems):
        return [Problem(str(out), f"the {len(digests):,} scene files {lock_file.name} lists", "none of them")]
    known = {Path(out, r) for r in digests}
    folders = sorted({p.parent for p in known})
    for folder in folders:
        for path in sorted(folder.glob("*.json")):
            if path not in known:
                problems.append(Problem(str(path), f"only the files {lock_file.name} lists", "an extra file"))
    return problems
