"""A batched vector environment that scales with cores (DESIGN section 6).

:class:`VectorEnv` runs ``num_envs`` citygen environments behind one Gymnasium
:class:`gymnasium.vector.VectorEnv` interface: an array of actions in, a batch of
observations, rewards, terminations and truncations out; every sub-environment runs its
own scene and draws a new one on each of its resets (asynchronous scene sampling).

With ``processes=True`` the sub-environments live in worker processes and step in parallel
with each other. Actions, observations, rewards and done flags travel through shared
memory; a step costs each worker one byte down a pipe and an empty message back, so nothing
is pickled per step. A worker pickles its ``info`` only on the last step of an episode (it
holds the task's metrics) and on resets, unless ``step_infos=True``. While there are cores
for them (``num_envs`` at most the cores), each sub-environment has a worker of its own;
beyond that there is one process per core, each stepping its group of sub-environments one
after another (8 on 2 cores: two groups of 4), so a step wakes a process per core rather
than one per sub-environment, and the sub-environments of a process share its cache of
compiled scenes. When the environments render no images, this process steps the first
group (or the first sub-environment) itself while the workers step the others, and both
sides of a pipe poll it for up to :data:`SPIN_S` before they sleep on it: on an otherwise
idle core, waking a sleeping process costs more than a step's physics. Which process steps
a sub-environment changes nothing it returns: each has its own scenes and seeds. With
``processes=False`` the sub-environments step one after another in this process, behind
the same interface.

Autoreset is Gymnasium's *next step* mode by default (``metadata["autoreset_mode"]``): the
step after a sub-environment's episode ended resets it (reward 0, not done) and returns its
first observation, so the last observation of an episode is the one returned with its end.
``autoreset_mode=AutoresetMode.SAME_STEP`` (what Stable-Baselines3 expects) resets it within
the step that ended the episode: that step returns the new episode's first observation,
the episode's reward and done flags, and the last observation and info under
``info["final_obs"]`` and ``info["final_info"]`` (batched as Gymnasium's ``SyncVectorEnv``
does), pickled by the worker on that step only.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import pickle
import time
import traceback
from collections.abc import Callable, Sequence
from typing import Any

import cloudpickle
import gymnasium
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space, create_shared_memory, read_from_shared_memory

_STEP, _RESET, _CALL, _CLOSE = b"s", b"r", b"c", b"q"
#: Seconds a process polls a pipe before it blocks on it (when every process has a core).
SPIN_S = 0.002
_OK, _ERROR = b"o", b"e"
#: Key of a same-step autoreset's ``(last observation, last info)`` in a slot's info.
_FINAL = "\0final"


class _Slot:
    """One sub-environment and its rows of the shared buffers: the code that steps it is the
    same in a worker process and in this one."""

    def __init__(
        self, env: gymnasium.Env, index: int, buffers: dict[str, Any], step_infos: bool, same_step: bool
    ):
        self.env, self.i, self.step_infos, self.same_step = env, index, step_infos, same_step
        self.obs = buffers["obs"]
        self.actions, self.rewards = buffers["actions"], buffers["rewards"]
        self.terminated, self.truncated = buffers["terminated"], buffers["truncated"]
        self.needs_reset = False

    def _write(self, obs: dict[str, np.ndarray] | np.ndarray) -> None:
        if isinstance(self.obs, dict):
            for key, value in obs.items():
                self.obs[key][self.i] = value
        else:
            self.obs[self.i] = obs

    def reset(self, seed: int | None, options: dict | None) -> dict[str, Any]:
        obs, info = self.env.reset(seed=seed, options=options)
        self._write(obs)
        self.rewards[self.i] = 0.0
        self.terminated[self.i] = self.truncated[self.i] = False
        self.needs_reset = False
        return info

    def step(self) -> dict[str, Any] | None:
        """Step with this slot's action (or reset if its episode ended at the last step);
        returns the info worth sending (the episode's last, or every one if asked)."""
        if self.needs_reset:
            info = self.reset(None, None)
            return info if self.step_infos else None
        obs, reward, term, trunc, info = self.env.step(self.actions[self.i])
        done = bool(term or trunc)
        if done and self.same_step:
            first = self.reset(None, None)
            self.rewards[self.i] = reward
            self.terminated[self.i], self.truncated[self.i] = term, trunc
            return {**first, _FINAL: (obs, info)}
        self._write(obs)
        self.rewards[self.i] = reward
        self.terminated[self.i], self.truncated[self.i] = term, trunc
        self.needs_reset = done
        return info if (self.needs_reset or self.step_infos) else None


def _buffers(obs_space, act_space, n: int, ctx) -> dict[str, Any]:
    """Shared arrays (``ctx`` given) or plain ones: observations, actions, rewards, flags."""
    if ctx is None:
        from gymnasium.vector.utils import create_empty_array

        obs = create_empty_array(obs_space, n)
        return {
            "obs": obs,
            "actions": create_empty_array(act_space, n),
            "rewards": np.zeros(n),
            "terminated": np.zeros(n, dtype=bool),
            "truncated": np.zeros(n, dtype=bool),
        }
    return {
        "obs": create_shared_memory(obs_space, n, ctx),
        "actions": create_shared_memory(act_space, n, ctx),
        "rewards": ctx.Array("d", n, lock=False),
        "terminated": ctx.Array("b", n, lock=False),
        "truncated": ctx.Array("b", n, lock=False),
    }


def _views(raw: dict[str, Any], obs_space, act_space, n: int) -> dict[str, Any]:
    """Numpy views of :func:`_buffers`' shared arrays."""
    return {
        "obs": read_from_shared_memory(obs_space, raw["obs"], n),
        "actions": read_from_shared_memory(act_space, raw["actions"], n),
        "rewards": np.frombuffer(raw["rewards"], dtype=np.float64),
        "terminated": np.frombuffer(raw["terminated"], dtype=bool),
        "truncated": np.frombuffer(raw["truncated"], dtype=bool),
    }


def _receive(conn, spin: float) -> bytes:
    """The next message on ``conn``, polled for up to ``spin`` seconds before blocking."""
    if spin > 0.0:
        deadline = time.perf_counter() + spin
        while not conn.poll() and time.perf_counter() < deadline:
            pass
    return conn.recv_bytes()


def _worker(
    makes: bytes, first: int, raw, spaces, n: int, step_infos: bool, same_step: bool, spin: float, conn
):
    """A worker process's loop: its sub-environments (``makes``: their functions, one
    cloudpickled list; indices ``first``, ``first + 1``, ...), stepped one after another on
    each command from ``conn`` (polled for ``spin`` seconds before blocking). Every answer
    holds one entry per sub-environment, or nothing when a step has no info to send."""
    envs: list[gymnasium.Env] = []
    try:
        for make in pickle.loads(makes):
            envs.append(make())
        views = _views(raw, *spaces, n)
        slots = [_Slot(env, first + k, views, step_infos, same_step) for k, env in enumerate(envs)]
        conn.send_bytes(_OK)
        while True:
            msg = _receive(conn, spin)
            cmd = msg[:1]
            try:
                if cmd == _STEP:
                    infos = [slot.step() for slot in slots]
                    none = all(info is None for info in infos)
                    conn.send_bytes(_OK if none else _OK + pickle.dumps(infos))
                elif cmd == _RESET:
                    seeds, options = pickle.loads(msg[1:])
                    infos = [slot.reset(seed, options) for slot, seed in zip(slots, seeds, strict=True)]
                    conn.send_bytes(_OK + pickle.dumps(infos))
                elif cmd == _CALL:
                    name, each_args, kwargs = pickle.loads(msg[1:])  # one args tuple per slot
                    out = []
                    for env, args in zip(envs, each_args, strict=True):
                        attr = getattr(env, name)
                        out.append(attr(*args, **kwargs) if callable(attr) else attr)
                    conn.send_bytes(_OK + pickle.dumps(out))
                else:
                    conn.send_bytes(_OK)
                    break
            except Exception as exc:  # the parent re-raises it
                conn.send_bytes(_ERROR + pickle.dumps((exc, traceback.format_exc())))
    except (EOFError, BrokenPipeError):
        pass  # the parent is gone (killed): nobody to report to, nothing to print
    except Exception as exc:
        conn.send_bytes(_ERROR + pickle.dumps((exc, traceback.format_exc())))
    except KeyboardInterrupt:
        pass
    finally:
        for env in envs:
            env.close()
        conn.close()


def _groups(count: int, workers: int) -> list[int]:
    """How many of ``count`` sub-environments each of ``workers`` processes steps: as even as
    can be, the larger groups first."""
    q, r = divmod(count, workers)
    return [q + (k < r) for k in range(workers)]


@contextlib.contextmanager
def _main_not_rerun():
    """Start a worker without re-running a main script that is not a file: a script read from
    standard input (``python - <<EOF``) has ``__main__.__file__ == '<stdin>'``, which spawn and
    forkserver workers would try to run again and die on (a BrokenPipe or EOFError here). The
    workers need nothing from it: their environments come cloudpickled."""
    import os
    import sys

    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if path is None or os.path.exists(path):
        yield
        return
    del main.__file__
    try:
        yield
    finally:
        main.__file__ = path


class VectorEnv(gymnasium.vector.VectorEnv):
    """``len(env_fns)`` sub-environments, each built by its function, batched (see the module
    docstring). ``processes``: worker processes step the sub-environments (``context``: the
    multiprocessing start method, default ``"forkserver"``: a worker starts from a fresh
    interpreter, so its scene cache starts empty); ``local``: how many of them (the first)
    step in this process instead, in parallel with the workers (default, when the
    environments render no images: 1 while ``num_envs`` <= the cores this process may use,
    else a core's share, ``ceil(num_envs / cores)``; 0 when they render); ``workers``: how
    many worker processes step the rest, in groups as even as can be (default: one per
    sub-environment while ``num_envs`` <= the cores, else one per core this process leaves
    free); ``copy``: return copies of the
    observation buffers (False: views that the next step overwrites); ``autoreset_mode``:
    Gymnasium's ``NEXT_STEP`` (default) or ``SAME_STEP`` (see the module docstring)."""

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP}

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gymnasium.Env]],
        *,
        processes: bool = True,
        local: int | None = None,
        workers: int | None = None,
        context: str | None = None,
        copy: bool = True,
        step_infos: bool = False,
        autoreset_mode: AutoresetMode = AutoresetMode.NEXT_STEP,
    ):
        if not env_fns:
            raise ValueError("VectorEnv: expected at least one environment function, got none")
        if autoreset_mode not in (AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP):
            raise ValueError(
                f"VectorEnv: autoreset_mode: expected NEXT_STEP or SAME_STEP, got {autoreset_mode}"
            )
        same = autoreset_mode == AutoresetMode.SAME_STEP
        n = self.num_envs = len(env_fns)
        first = env_fns[0]()
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.metadata = {**first.metadata, "autoreset_mode": autoreset_mode}
        self.render_mode = first.render_mode
        self.observation_space = batch_space(self.single_observation_space, n)
        self.action_space = batch_space(self.single_action_space, n)
        self.copy, self.closed = copy, False
        spaces = (self.single_observation_space, self.single_action_space)
        self._conns: list[Any] = []
        self._procs: list[Any] = []
        self._counts: list[int] = []  # sub-environments of each worker, in order
        self._spin = 0.0
        if not processes:
            self._bufs = _buffers(*spaces, n, None)
            envs = [first] + [fn() for fn in env_fns[1:]]
            self._slots = [_Slot(e, i, self._bufs, step_infos, same) for i, e in enumerate(envs)]
            return
        from citygen.generate.dataset import default_jobs

        cores = default_jobs()  # the cores this process may run on, not the host's
        if local is None:
            # Not an environment that renders: its renderers (a GL context each, 80-160 MB and
            # ~0.3 s to make, one per scene) would crowd this process's few (envs.RENDERERS).
            unwrapped = getattr(first, "unwrapped", first)
            renders = getattr(unwrapped, "use_depth", False) or getattr(unwrapped, "use_rgb", False)
            # Every process its core: this one steps its share (a core's) beside the workers.
            local = 0 if n == 1 or renders else 1 if n <= cores else -(-n // cores)
        if not 0 <= local <= n:
            raise ValueError(f"VectorEnv: local: expected 0 to {n} sub-environments, got {local}")
        if workers is None:
            # One process per sub-environment while there are cores for them; beyond that one
            # per core, each stepping its group in turn: a step wakes a process per core,
            # not one per sub-environment (8 on 2 cores: 640 -> 810-890 steps/s).
            rest = n - local
            workers = rest if n <= cores else min(rest, max(cores - (local > 0), 1))
        if not (min(1, n - local) <= workers <= n - local):
            raise ValueError(
                f"VectorEnv: workers: expected {min(1, n - local)} to {n - local} processes for the "
                f"{n - local} sub-environments not in this one, got {workers}"
            )
        # Polling pays only when no process has to wait for a core another one polls on.
        self._spin = SPIN_S if workers + 1 <= cores else 0.0
        # A fresh interpreter per worker (forkserver): forking a process that holds a GL
        # context (a renderer) leaves the child's EGL hanging.
        methods = mp.get_all_start_methods()
        ctx = mp.get_context(context or ("forkserver" if "forkserver" in methods else "spawn"))
        raw = _buffers(*spaces, n, ctx)
        self._bufs = _views(raw, *spaces, n)
        envs = [first] + [fn() for fn in env_fns[1:local]] if local else []
        if not local:
            first.close()
        self._slots = [_Slot(e, i, self._bufs, step_infos, same) for i, e in enumerate(envs)]
        start = local
        for count in _groups(n - local, workers) if workers else []:
            parent, child = ctx.Pipe()
            makes = cloudpickle.dumps(list(env_fns[start : start + count]))
            args = (makes, start, raw, spaces, n, step_infos, same, self._spin, child)
            name = f"citygen-vector-{start}" + (f"-{start + count - 1}" if count > 1 else "")
            proc = ctx.Process(target=_worker, args=args, daemon=True, name=name)
            with _main_not_rerun():
                proc.start()
            child.close()
            self._conns.append(parent)
            self._procs.append(proc)
            self._counts.append(count)
            start += count
        try:
            self._collect()
        except BaseException:
            self.close_extras()  # the workers that did start stop with the one that failed
            raise

    # --- plumbing ------------------------------------------------------------------------

    def _collect(self) -> list[Any]:
        """The workers' answers to the last command, one per sub-environment in order: the
        unpickled payload or None."""
        out, error = [], None
        for conn, count in zip(self._conns, self._counts, strict=True):
            msg = _receive(conn, self._spin)
            if msg[:1] == _ERROR:
                exc, tb = pickle.loads(msg[1:])
                error = error or (exc, tb)
                out += [None] * count
            else:
                out += pickle.loads(msg[1:]) if len(msg) > 1 else [None] * count
        if error is not None:
            exc, tb = error
            exc.add_note(f"in a citygen vector-env worker:\n{tb}")
            raise exc
        return out

    def _split(self, values: Sequence[Any]) -> list[list[Any]]:
        """The workers' sub-environments' share of ``values`` (one per sub-environment in a
        worker, in order), one list per worker."""
        out, start = [], 0
        for count in self._counts:
            out.append(list(values[start : start + count]))
            start += count
        return out

    def _here(self, work: Callable[[], list[Any]]) -> list[Any]:
        """``work()`` on this process's sub-environments while the workers run the command
        just sent; if it raises, the workers' answers are read first (the pipes stay in step)."""
        try:
            return work()
        except BaseException:
            with contextlib.suppress(BaseException):
                self._collect()
            raise

    def _obs(self):
        obs = self._bufs["obs"]
        if not self.copy:
            return obs
        return {k: v.copy() for k, v in obs.items()} if isinstance(obs, dict) else obs.copy()

    def _infos(self, infos: list[dict | None]) -> dict[str, Any]:
        out: dict[str, Any] = {}
        for i, info in enumerate(infos):
            if not info:
                continue
            if _FINAL in info:  # as Gymnasium's own same-step vector envs batch them
                info = dict(info)
                final_obs, final_info = info.pop(_FINAL)
                out = self._add_info(out, {"final_obs": final_obs, "final_info": final_info}, i)
            out = self._add_info(out, info, i)
        return out

    # --- the Gymnasium interface ---------------------------------------------------------

    def reset(self, *, seed: int | Sequence[int | None] | None = None, options: dict | None = None):
        n = self.num_envs
        if isinstance(seed, Sequence):
            seeds = list(seed)
        else:
            seeds = [None if seed is None else seed + i for i in range(n)]
        if len(seeds) != n:
            raise ValueError(f"reset: expected {n} seeds, got {len(seeds)}")
        k = len(self._slots)
        for conn, part in zip(self._conns, self._split(seeds[k:]), strict=True):
            conn.send_bytes(_RESET + pickle.dumps((part, options)))
        infos = self._here(
            lambda: [s.reset(sd, options) for s, sd in zip(self._slots, seeds[:k], strict=True)]
        )
        infos += self._collect()
        return self._obs(), self._infos(infos)

    def step(self, actions):
        b = self._bufs
        b["actions"][...] = np.asarray(actions).reshape(b["actions"].shape)
        for conn in self._conns:  # the workers step while this process steps its own
            conn.send_bytes(_STEP)
        infos = self._here(lambda: [s.step() for s in self._slots])
        infos += self._collect()
        return (
            self._obs(),
            b["rewards"].copy(),
            b["terminated"].copy(),
            b["truncated"].copy(),
            self._infos(infos),
        )

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """``name(*args, **kwargs)`` on every sub-environment (or the attribute's value)."""
        for conn, count in zip(self._conns, self._counts, strict=True):
            conn.send_bytes(_CALL + pickle.dumps((name, [args] * count, kwargs)))

        def mine():
            attrs = [getattr(s.env, name) for s in self._slots]
            return [a(*args, **kwargs) if callable(a) else a for a in attrs]

        return (*self._here(mine), *self._collect())

    def get_attr(self, name: str) -> tuple[Any, ...]:
        return self.call(name)

    def set_attr(self, name: str, values: Any) -> None:
        """Set ``name`` on every sub-environment: to ``values[i]`` for a list or tuple of one
        value each, else to ``values``."""
        if not isinstance(values, list | tuple):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise ValueError(f"set_attr: expected {self.num_envs} values, got {len(values)}")
        k = len(self._slots)
        for s, v in zip(self._slots, values[:k], strict=True):
            setattr(s.env, name, v)
        for conn, part in zip(self._conns, self._split(values[k:]), strict=True):
            conn.send_bytes(_CALL + pickle.dumps(("__setattr__", [(name, v) for v in part], {})))
        self._collect()

    def close_extras(self, **kwargs: Any) -> None:
        for s in self._slots:
            s.env.close()
        for conn in self._conns:
            try:
                conn.send_bytes(_CLOSE)
                conn.recv_bytes()
            except (OSError, EOFError):
                pass
            conn.close()
        for proc in self._procs:
            proc.join(timeout=5)
            if proc.is_alive():
                proc.terminate()
        self._conns, self._procs, self._slots, self._counts = [], [], [], []
