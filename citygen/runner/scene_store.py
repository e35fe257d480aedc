"""A persistent on-disk cache of prepared scenes, shared by workers and runs.

Preparing a scene for an environment (generating a split's scene, compiling its MJCF with the
robot attached, rasterising its occupancy map, free space and crossable cells) costs about
140 ms for an Urban-Nav scene on the 2-core machine, every time a process first visits it: a
vector environment's workers each pay it, and so does every new run. The process's
:class:`~citygen.runner.scenes.SceneCache` keeps scenes for one process; this store keeps
them on disk, so that a first visit in a second run (or a second worker) reads a file of
~200 KB instead (a few milliseconds).

Entries are keyed by content: the scene's (a file's or a given scene's canonical JSON, or a
split's config, seed and index), the robot's (name, timestep, MJCF), and the code's (every
source file of citygen and its exporters, MuJoCo's version), so an edited scene, robot or
generator never reads a stale entry. An entry is the prepared scene pickled without its
scene, then the scene (a caller that holds the scene, the one whose content names the entry,
does not unpickle it: 0.4 s on a city), compressed when smaller than
:data:`COMPRESS_BELOW`, written atomically; a model of :data:`MJB_FROM` bytes or
more (a city's: 269 MB) is kept beside it in MuJoCo's own binary format (``mj_saveModel``, read
back by ``MjModel.from_binary_path``: a third of unpickling's time, which copies the bytes
twice). One that cannot be read (truncated, from another version) is a miss and is written
again. The store is bounded
(:data:`BUDGET_MB`, oldest entries removed first) and never fails a run: an unwritable folder
only means no entries are kept.

Beside an entry the store keeps arrays a scene's first episode derives from it and that cost
more to compute than to read (:meth:`SceneStore.load_array`, :meth:`SceneStore.save_array`):
a city crowd's path tables (:func:`citygen.runner.agents.crowd.crowd_of`, 0.4 GB, seconds
of Dijkstra), as ``.npy`` files read memory-mapped. One that cannot be read, or fails its
reader's check, is a miss and is computed (and written) again.

Where: ``$CITYGEN_CACHE_DIR/scenes`` (default ``$XDG_CACHE_HOME/citygen``, else
``~/.cache/citygen``); ``CITYGEN_CACHE_DIR=off`` turns the store off. Entries are pickles:
like any cache of pickles, the folder must be one only you write to.
"""

from __future__ import annotations

import contextlib
import dataclasses
import functools
import hashlib
import io
import os
import pickle
import tempfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

#: Environment variable naming the cache folder ("off" turns the store off).
ENV = "CITYGEN_CACHE_DIR"
#: Disk (MiB) the store keeps; the oldest entries go first beyond it.
BUDGET_MB = 2048
#: Entries written between two checks of the budget.
CHECK_EVERY = 64
#: Bumped when an entry's layout changes (4: the scene pickled after the prepared scene
#: without it, so that a caller holding the scene does not unpickle it, 0.4 s on a city; 5:
#: an entry whose model is kept apart records the ``.mjb``'s length, checked before MuJoCo reads it).
FORMAT = 5
#: Pickles of more bytes than this are stored as they are, smaller ones compressed (zlib):
#: decompressing a city's entry (360 MB, 89 MB compressed) cost 1.3 s of a reset from the
#: store and compressing it 1.2 s of the first; an Urban-Nav scene's stays ~200 KB.
COMPRESS_BELOW = 32 << 20
#: Models of this many bytes (``model.nbuffer``) or more are stored beside their entry as an
#: ``.mjb`` file rather than in its pickle: loading a town's 40 MB model from it took 0.06 s of
#: CPU where unpickling took 0.19 s (the city's, 269 MB, 1.4 s unpickled).
MJB_FROM = 16 << 20


def folder() -> Path | None:
    """The store's folder, or None when ``CITYGEN_CACHE_DIR=off`` (or empty)."""
    text = os.environ.get(ENV)
    if text is not None:
        text = text.strip()
        return None if text.lower() in ("", "off", "0", "none") else Path(text).expanduser() / "scenes"
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "citygen" / "scenes"


@functools.cache
def code_digest() -> str:
    """A digest of the code a prepared scene depends on: every Python source of citygen and
    of its exporters, and MuJoCo's version."""
    import mujoco

    from citygen import exporters

    h = hashlib.sha256(f"{FORMAT} {mujoco.__version__}".encode())
    package = Path(__file__).resolve().parents[1]  # citygen/
    roots = {package, Path(exporters.__file__).parent.resolve()}
    for root in sorted(roots):
        for path in sorted(root.rglob("*.py")):
            h.update(str(path.relative_to(root)).encode())
            h.update(path.read_bytes())
    return h.hexdigest()


def entry_key(scene_key: str, robot: Any, terrain: str = "heightfield") -> str:
    """The key of a scene (its content key, see :meth:`SceneSource.content_key`) with a robot,
    its terrain compiled as ``terrain`` says (:data:`citygen.runner.scenes.TERRAIN_OPTIONS`)."""
    xml = hashlib.sha256(robot.xml.encode()).hexdigest()
    robot_key = f"{robot.name} {robot.timestep!r} {robot.cone} {xml} {terrain}"
    return hashlib.sha256(f"{code_digest()}\n{scene_key}\n{robot_key}".encode()).hexdigest()


class SceneStore:
    """Prepared scenes on disk under ``root`` (see the module docstring)."""

    def __init__(self, root: Path, budget_mb: float = BUDGET_MB):
        self.root = Path(root)
        self.budget = int(budget_mb * 2**20)
        self.hits = 0
        self.misses = 0
        self.writes = 0
        self._unwritable = False

    def path(self, key: str) -> Path:
        return self.root / key[:2] / f"{key}.pkl.z"

    def load(self, key: str, robot: Any, scene: Any = None) -> Any | None:
        """The prepared scene stored under ``key`` with ``robot`` attached, or None. ``scene``:
        the scene the entry was prepared from, when the caller holds it (the key names its
        content): it is attached as it is, the stored copy left unread."""
        path = self.path(key)
        try:
            blob = path.read_bytes()
        except OSError:
            self.misses += 1
            return None
        model_path = self.model_path(key)
        try:
            # a pickle starts with its PROTO opcode (0x80); a zlib stream never does
            stream = io.BytesIO(blob if blob[:1] == b"\x80" else zlib.decompress(blob))
            prepared = pickle.load(stream)  # without its scene, which follows
            if scene is None:
                scene = pickle.load(stream)
            model = prepared.model
            if isinstance(model, _Apart):  # kept beside the entry (MJB_FROM)
                import mujoco

                # checked here: MuJoCo warns of a truncated file into MUJOCO_LOG.TXT in the
                # user's working folder
                if model_path.stat().st_size != model.nbytes:
                    raise ValueError(f"{model_path}: truncated")
                model = mujoco.MjModel.from_binary_path(str(model_path))
        except Exception:  # truncated, or written by another version: a miss, written again
            self.misses += 1
            for p in (path, model_path):
                with contextlib.suppress(OSError):
                    p.unlink()
            return None
        for p in (path, model_path):
            with contextlib.suppress(OSError):
                os.utime(p)  # recently used: the last to go
        self.hits += 1
        return dataclasses.replace(prepared, scene=scene, robot=robot, model=model)

    def save(self, key: str, prepared: Any) -> None:
        """Store ``prepared`` under ``key`` (atomically; nothing when the folder is unwritable)."""
        model = prepared.model
        apart = None
        if int(model.nbuffer) >= MJB_FROM:  # the model first: an entry is only read with its model there
            import mujoco

            data = _model_bytes(mujoco, model)
            self._write(self.model_path(key), lambda f: f.write(data), check=False)
            apart = _Apart(data.nbytes)
        kept = dataclasses.replace(
            prepared, scene=None, robot=None, store_key=None, _fields={}, _routes={}, _windows={},
            model=model if apart is None else apart,
        )  # fmt: skip
        blob = pickle.dumps(kept, protocol=pickle.HIGHEST_PROTOCOL)
        blob += pickle.dumps(prepared.scene, protocol=pickle.HIGHEST_PROTOCOL)
        if len(blob) < COMPRESS_BELOW:
            blob = zlib.compress(blob, 1)
        self._write(self.path(key), lambda f: f.write(blob))

    def model_path(self, key: str) -> Path:
        """Where entry ``key``'s model is kept when it is big (:data:`MJB_FROM`)."""
        return self.root / key[:2] / f"{key}.mjb"

    def array_path(self, key: str, name: str) -> Path:
        return self.root / key[:2] / f"{key}.{name}.npy"

    def load_array(self, key: str, name: str, check: Any = None) -> np.ndarray | None:
        """The array ``name`` kept beside entry ``key``, memory-mapped read-only, or None when
        there is none, it cannot be read, or ``check(array)`` is false (a broken file is
        removed, to be written again)."""
        path = self.array_path(key, name)
        if not path.is_file():
            self.misses += 1
            return None
        try:
            array = np.load(path, mmap_mode="r", allow_pickle=False)
            ok = check is None or bool(check(array))
        except Exception:  # truncated, not an .npy, the wrong layout
            ok = False
        if not ok:
            self.misses += 1
            with contextlib.suppress(OSError):
                path.unlink()
            return None
        with contextlib.suppress(OSError):
            os.utime(path)
        self.hits += 1
        return array

    def save_array(self, key: str, name: str, array: np.ndarray) -> None:
        """Keep ``array`` as ``name`` beside entry ``key`` (atomically; nothing when unwritable)."""
        self._write(self.array_path(key, name), lambda f: np.save(f, np.ascontiguousarray(array)))

    def _write(self, path: Path, write: Any, check: bool = True) -> None:
        """``write(file)`` to a temporary file renamed to ``path``; nothing when unwritable;
        ``check``: count the write and keep to the budget (not for a part of an entry written
        first, which the budget must not remove before its entry is written)."""
        if self._unwritable:
            return
        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-")
            try:
                with os.fdopen(fd, "wb") as f:
                    write(f)
                os.replace(tmp, path)
            except BaseException:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
                raise
        except OSError:  # read-only, full, not a folder: run on without the store
            self._unwritable = True
            return
        if not check:
            return
        self.writes += 1
        if self.writes % CHECK_EVERY == 1:
            self.prune()

    def prune(self) -> None:
        """Remove the least recently used entries until the store is within its budget."""
        entries = []
        for path in [*self.root.glob("*/*.pkl.z"), *self.root.glob("*/*.mjb"), *self.root.glob("*/*.npy")]:
            with contextlib.suppress(OSError):
                st = path.stat()
                entries.append((st.st_mtime, st.st_size, path))
        total = sum(size for _, size, _ in entries)
        for _, size, path in sorted(entries):
            if total <= self.budget:
                break
            with contextlib.suppress(OSError):
                path.unlink()
                total -= size


@dataclasses.dataclass(frozen=True)
class _Apart:
    """In a stored entry, in place of its model: kept in the ``.mjb`` beside it, ``nbytes`` long."""

    nbytes: int


def _model_bytes(mujoco: Any, model: Any) -> np.ndarray:
    """``model`` in MuJoCo's binary format (the bytes ``mj_saveModel`` writes to a file)."""
    buffer = np.empty(mujoco.mj_sizeModel(model), dtype=np.uint8)
    mujoco.mj_saveModel(model, None, buffer)
    return buffer


@functools.cache
def _store(root: Path) -> SceneStore:
    return SceneStore(root)


def store() -> SceneStore | None:
    """The store of this process (its folder as :func:`folder` gives it now), or None if off."""
    root = folder()
    return None if root is None else _store(root)
